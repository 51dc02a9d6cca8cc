"""The checker's robot functions compiled to C: the same expressions, evaluated faster.

The checker evaluates five of the robot's own functions (:attr:`Robot.functions`) at every
sample: ``ee_position``, ``collision_points``, ``tau``, ``pfaffian`` and ``manipulability``.
On the CasADi virtual machine the efforts ``tau`` (mass matrix and bias forces: ~9000
instructions for a youBot) take ~50 ms for 600 samples; compiled to C, ~5 ms. The library is
generated from the robot's symbolic model alone (nothing a planner built or wrote), cached on
disk like the planners' libraries (:mod:`mmplan.compile.codegen`) and keyed by the model's
fingerprint (:func:`~mmplan.compile.fingerprint.robot_fingerprint`) and the code that makes the
functions; the compiled functions give the numbers of the virtual machine (the same expression
graph; the tests compare them).

Opt-in, per robot object: :func:`compiled_checks` (the ``mmplan`` commands) loads the library
when it is on disk and, with ``build=True``, starts building it in the background when it is
not (a check meanwhile runs on the virtual machine; the build is waited for when the block
ends, so the next run finds it). Elsewhere, or without a C compiler,
:func:`check_functions` is the robot's own functions.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from threading import Thread
from weakref import WeakKeyDictionary

import casadi as ca

from mmplan.compile import codegen
from mmplan.compile.fingerprint import robot_fingerprint, source_fingerprint
from mmplan.robot import robot as robot_module
from mmplan.robot.robot import Robot

#: The robot functions the checker maps over the samples (the compiled library holds these).
NAMES = ("ee_position", "collision_points", "tau", "pfaffian", "manipulability")
PREFIX = "check"
#: -O1: a youBot's library builds in ~1.5 s (-O2: ~3 s) and runs as fast.
FLAGS = ("-O1",)
#: Largest model built (operations of the five functions): the youBots (~10k, ~18k), the
#: planar robots (< 7k); not base-6dof (~46k), ur5-omni (~41k), tiago (~100k), whose build
#: would take longer than many checks gain (a library built before is used whatever its size).
MAX_INSTRUCTIONS = 20_000


@dataclass
class _Entry:
    key: str
    functions: dict[str, ca.Function] | None = None


#: The robots inside a :func:`compiled_checks` block (held weakly).
_ENTRIES: WeakKeyDictionary[Robot, _Entry] = WeakKeyDictionary()


class _NotBuiltError(Exception):
    """Raised instead of making the functions: only a library already on disk is wanted."""


def _not_built() -> list[ca.Function]:
    raise _NotBuiltError


def library_key(robot: Robot) -> str:
    """Disk-cache key of the robot's checker library: its model and the code of the functions."""
    code = source_fingerprint([robot_module.__file__ or "", __file__])
    return f"{robot_fingerprint(robot)}|{code}|{','.join(NAMES)}"


def _cached_library(key: str) -> str | None:
    """Path of the library of ``key`` when it is on disk (and a compiler exists), else None."""
    try:
        return codegen.compile_library(_not_built, PREFIX, FLAGS, key=key)
    except _NotBuiltError:
        return None


def check_functions(robot: Robot) -> Mapping[str, ca.Function]:
    """The functions the checker evaluates: compiled ones for a robot inside
    :func:`compiled_checks` whose library is on disk, else :attr:`Robot.functions`."""
    entry = _ENTRIES.get(robot)
    if entry is None:
        return robot.functions
    if entry.functions is None:
        path = _cached_library(entry.key)
        if path is None:
            return robot.functions
        try:
            entry.functions = dict(zip(NAMES, codegen.load(NAMES, path), strict=True))
        except RuntimeError:  # an unloadable file: the virtual machine, as without a compiler
            entry.functions = {n: robot.functions[n] for n in NAMES}
    return entry.functions


def _size(robot: Robot) -> int:
    """Operations of the checker's functions of ``robot`` (CasADi instructions)."""
    return sum(int(robot.functions[n].n_instructions()) for n in NAMES)


@contextmanager
def compiled_checks(robot: Robot, *, build: bool = False) -> Iterator[None]:
    """Inside the block, :func:`mmplan.verify.check.check` of a trajectory of ``robot`` (this
    object) evaluates the compiled functions when their library is on disk.

    Args:
        robot: The robot whose trajectories will be checked.
        build: Build a missing library in the background (a C compiler in a thread; the
            block's end waits for it unless the block ends with an interrupt), for a model of
            at most ``MAX_INSTRUCTIONS`` operations.
    """
    if codegen.compiler() is None:
        yield
        return
    key = library_key(robot)
    outer = _ENTRIES.get(robot)
    _ENTRIES[robot] = _Entry(key)
    thread: Thread | None = None
    if build and _cached_library(key) is None and _size(robot) <= MAX_INSTRUCTIONS:
        thread = codegen.start_build(lambda: [robot.functions[n] for n in NAMES], PREFIX, key,
                                     FLAGS)
    try:
        yield
    except (KeyboardInterrupt, GeneratorExit):
        thread = None
        raise
    finally:
        if outer is None:
            _ENTRIES.pop(robot, None)
        else:
            _ENTRIES[robot] = outer
        if thread is not None:
            thread.join()


def library_path(robot: Robot) -> Path | None:
    """The robot's checker library when it is on disk (for tests and benchmarks)."""
    path = _cached_library(library_key(robot))
    return None if path is None else Path(path)


__all__ = ["FLAGS", "MAX_INSTRUCTIONS", "NAMES", "check_functions", "compiled_checks",
           "library_key", "library_path"]
