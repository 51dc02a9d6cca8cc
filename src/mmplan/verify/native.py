"""The checker's robot functions compiled to C: the same expressions, evaluated faster.

The checker evaluates five of the robot's own functions (:attr:`Robot.functions`) at every
sample: ``ee_position``, ``collision_points``, ``tau``, ``pfaffian`` and ``manipulability``.
On the CasADi virtual machine the efforts ``tau`` (mass matrix and bias forces: ~9000
instructions for a youBot) take ~50 ms for 600 samples; compiled to C, ~5 ms. The library is
the robot's own (:mod:`mmplan.robot.compiled`): generated from its symbolic model alone
(nothing a planner built or wrote), cached on disk like the planners' libraries and keyed by
the model's fingerprint and the code that makes the functions; the compiled functions give
the numbers of the virtual machine (the same expression graph; the tests compare them).

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
from mmplan.robot import compiled as robot_compiled
from mmplan.robot.robot import Robot

#: The robot functions the checker maps over the samples (in the robot's compiled library).
NAMES = ("ee_position", "collision_points", "tau", "pfaffian", "manipulability")


@dataclass
class _Entry:
    functions: dict[str, ca.Function] | None = None  # loaded at the first check


#: The robots inside a :func:`compiled_checks` block (held weakly).
_ENTRIES: WeakKeyDictionary[Robot, _Entry] = WeakKeyDictionary()


def check_functions(robot: Robot) -> Mapping[str, ca.Function]:
    """The functions the checker evaluates: compiled ones for a robot inside
    :func:`compiled_checks` whose library is on disk, else :attr:`Robot.functions`."""
    entry = _ENTRIES.get(robot)
    if entry is None:
        return robot.functions
    if entry.functions is None:
        path = robot_compiled.cached_library(robot)
        if path is None:
            return robot.functions
        try:
            entry.functions = robot_compiled.Natives(path).externals(NAMES)
        except RuntimeError:  # an unloadable file: the virtual machine, as without a compiler
            entry.functions = {n: robot.functions[n] for n in NAMES}
    return entry.functions


@contextmanager
def compiled_checks(robot: Robot, *, build: bool = False) -> Iterator[None]:
    """Inside the block, :func:`mmplan.verify.check.check` of a trajectory of ``robot`` (this
    object) evaluates the compiled functions when their library is on disk.

    Args:
        robot: The robot whose trajectories will be checked.
        build: Build a missing library in the background (a C compiler in a thread; the
            block's end waits for it unless the block ends with an interrupt), for a model of
            at most :data:`mmplan.robot.compiled.MAX_INSTRUCTIONS` operations
            (:func:`mmplan.robot.compiled.start_build`:
            the robot's numeric API uses it too, from the next run on).
    """
    if codegen.compiler() is None:
        yield
        return
    outer = _ENTRIES.get(robot)
    _ENTRIES[robot] = _Entry()
    thread: Thread | None = robot_compiled.start_build(robot) if build else None
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
    """The robot's compiled library when it is on disk (for tests and benchmarks)."""
    path = robot_compiled.cached_library(robot)
    return None if path is None else Path(path)


__all__ = ["NAMES", "check_functions", "compiled_checks", "library_path"]
