"""The robot's functions compiled to C, loaded from the disk cache (speed; the same numbers).

The numeric API of :class:`~mmplan.robot.robot.Robot` (``ee_position``, ``jacobian``,
``pfaffian``, ``manipulability``, ``collision_points``, ``actuator_efforts``) evaluates the
robot's symbolic model on CasADi's virtual machine, which first needs the model: 42 ms of
every ``mmplan plan`` for youbot-3r (measured), spent by the scenario's start check, then
20-60 us a call. A library of those functions compiled to C is kept in the cache folder of
the planners' libraries (:mod:`mmplan.compile.codegen`), keyed by the model's fingerprint
(:func:`~mmplan.compile.fingerprint.robot_fingerprint`, computed without the model) and the
code that makes the functions. When it is on disk the numeric API calls it through ctypes
(:class:`~mmplan.compile.codegen.NativeFunction`) and the symbolic model is never built;
else the virtual machine, as before. The checker maps the same library's functions over a
plan's samples (:mod:`mmplan.verify.native`).

Built by :func:`start_build` (``mmplan plan`` starts it in the background while it plans and
waits for it at its end, so that the next run finds it), for models of at most
:data:`MAX_INSTRUCTIONS` operations. The same expression graphs compiled with
``-ffp-contract=off`` (:data:`mmplan.compile.codegen.FIXED_FLAGS`): the numbers of the virtual
machine to the bit (tests/robot/test_compiled.py), so a plan does not change with the cache.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from threading import Thread
from typing import Any

import casadi as ca
import numpy as np

from mmplan.arrays import Array
from mmplan.compile import codegen, threads
from mmplan.compile.fingerprint import robot_fingerprint, source_fingerprint

#: The functions of the library (names of :attr:`Robot.functions`).
NAMES = ("ee_position", "collision_points", "tau", "pfaffian", "manipulability", "jacobian",
         "ee_acceleration")
PREFIX = "robot"
#: -O1: a youBot's library builds in ~1.5 s (-O2: ~3 s) and runs as fast.
FLAGS = ("-O1",)
#: Largest model built (operations of the functions): the youBots (~10k, ~18k), the planar
#: robots (< 7k); not base-6dof (~46k), ur5-omni (~41k), tiago (~100k), whose build would take
#: longer than many runs gain (a library built before is used whatever its size).
MAX_INSTRUCTIONS = 20_000


class _NotBuiltError(Exception):
    """Raised instead of making the functions: only a library already on disk is wanted."""


def _not_built() -> list[ca.Function]:
    raise _NotBuiltError


def library_key(robot: Any) -> str:
    """Disk-cache key of the robot's library: its model and the code of the functions."""
    from mmplan.robot import robot as robot_module  # robot.py imports this module

    code = source_fingerprint([robot_module.__file__ or "", __file__, codegen.__file__])
    return f"{robot_fingerprint(robot)}|{code}|{','.join(NAMES)}"


def cached_library(robot: Any) -> str | None:
    """Path of the robot's library when it is on disk (and a compiler exists), else None."""
    try:
        return codegen.compile_library(_not_built, PREFIX, FLAGS, key=library_key(robot))
    except _NotBuiltError:
        return None


def size(robot: Any) -> int:
    """Operations of the library's functions (CasADi instructions; builds the model)."""
    return sum(int(robot.functions[n].n_instructions()) for n in NAMES)


def start_build(robot: Any) -> Thread | None:
    """Build the robot's library in the background (returned thread: join it before the
    process ends, else the build is lost) when it is not on disk, a compiler exists and the
    model has at most :data:`MAX_INSTRUCTIONS` operations; None otherwise."""
    if codegen.compiler() is None or cached_library(robot) is not None:
        return None
    if size(robot) > MAX_INSTRUCTIONS:
        return None
    return codegen.start_build(lambda: [robot.functions[n] for n in NAMES], PREFIX,
                               library_key(robot), FLAGS)  # fmt: skip


class Natives:
    """The library's functions called through ctypes, one point at a time (:meth:`call`)."""

    def __init__(self, path: str) -> None:
        self.path = path
        self._fns: dict[str, codegen.NativeFunction] = {}
        self._externals: dict[str, ca.Function] = {}
        # a function has one set of buffers and ctypes lets other threads run during the
        # call: one caller at a time (two threads on one robot gave wrong results, review)
        self._lock = threading.Lock()

    def function(self, name: str) -> codegen.NativeFunction:
        """The compiled function ``name`` (loaded at its first use)."""
        fn = self._fns.get(name)
        if fn is None:
            fn = self._fns[name] = codegen.NativeFunction(self.path, name)
        return fn

    def call(self, name: str, *args: Array) -> Array:
        """``name`` at one point: its inputs (each (n,)) in, its output as the virtual machine
        gives it (a full (rows, cols) array)."""
        with self._lock:
            fn = self.function(name)
            x = fn.x
            at = 0
            for a in args:
                x[at : at + len(a)] = a
                at += len(a)
            if at != len(x):
                raise ValueError(f"{name}: {at} input values for {len(x)}")
            fn()
            return fn.dense()

    def many(self, name: str, *args: Array) -> Array:
        """``name`` at N points: its inputs as (N, n) arrays, its outputs (N, rows * cols),
        each row the full output's entries column after column (a sparse output scattered
        into its matrix first; one ctypes call a point: 2.5 us for youbot-3r's collision
        points, where a mapped ``casadi.external`` spent 20 ms on 600 points, most in
        converting its output)."""
        cols = [np.asarray(a, dtype=float) for a in args]
        N = len(cols[0]) if cols else 0
        inputs = np.hstack(cols) if cols else np.zeros((0, 0))
        with self._lock:
            fn = self.function(name)
            x, y, pattern = fn.x, fn.y, fn.pattern
            if inputs.shape[1:] != x.shape:
                raise ValueError(f"{name}: {inputs.shape[1:]} input values for {len(x)}")
            out = np.empty((N, pattern.shape[0] * pattern.shape[1]))
            if fn.inputs == 1 and pattern.rows is None and N:  # one C loop over the points
                rows = np.ascontiguousarray(inputs, dtype=np.float64)
                if threads.call_rows(fn.signature(), rows, out):
                    return out
            for k in range(N):
                x[:] = inputs[k]
                fn()
                out[k] = y if pattern.rows is None else pattern.dense(y).ravel(order="F")
        return out

    def externals(self, names: Sequence[str] = NAMES) -> dict[str, ca.Function]:
        """The functions as ``casadi.external`` (to map them over many points; each loaded
        once)."""
        missing = [n for n in names if n not in self._externals]
        if missing:
            self._externals.update(zip(missing, codegen.load(missing, self.path), strict=True))
        return {n: self._externals[n] for n in names}


def natives(robot: Any, shared: dict[str, Any]) -> Natives | None:
    """The robot's compiled functions when their library is on disk (looked up once per model
    and cache folder: ``shared`` is the robot's store, kept by its copies), else None."""
    folder = str(codegen.cache_dir())
    memo = shared.get("natives", False)
    if memo is None or (isinstance(memo, tuple) and memo[0] == folder):
        return None if memo is None else memo[1]  # None: set by hand, the virtual machine
    path = cached_library(robot)
    found = None
    if path is not None:
        try:
            found = Natives(path)
            found.function(NAMES[0])  # loads the file: a bad one is the virtual machine
        except (OSError, AttributeError, RuntimeError, ValueError):
            found = None
    shared["natives"] = (folder, found)
    return found


__all__ = ["FLAGS", "MAX_INSTRUCTIONS", "NAMES", "Natives", "cached_library", "library_key",
           "natives", "size", "start_build"]
