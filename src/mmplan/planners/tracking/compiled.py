"""The trackers' control steps compiled to C, found again by what they are made of.

A step with the scene's obstacles as parameters (:mod:`.slots`) depends on the robot model,
the settings that enter its expressions, the obstacle kinds with their slot counts, the floor
and the code: that is the key of its library (:func:`disk_key`), so a moved, resized or new
obstacle of the same kinds, or another path, runs the same library, and a later process loads
it without building the tracker's symbolic model (the library also holds the functions the
planner calls besides the step: the task matrix, the impedance force). A scene with a shape
without a parametric form keeps its numbers built in and runs on CasADi's virtual machine (it
would compile per scene).
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import casadi as ca

from mmplan.compile import codegen as cg
from mmplan.compile import family as cf
from mmplan.compile.fingerprint import python_files, robot_fingerprint, source_fingerprint
from mmplan.planners.tracking.slots import Slots

#: C flags of a step (measured on diffdrive3-track's step: see docs/tracking.md).
FLAGS = ("-O1",)
#: Settings that do not enter a step's expressions (stop rules, horizon, this switch).
NOT_IN_STEP = {"t_max", "min_singular_value", "max_error", "settle_time", "stop_on_collision",
               "codegen", "method"}  # fmt: skip


def disk_key(robot: Any, name: str, settings: Any, slots: Slots | None, ground: Any) -> str:
    """What a compiled step ``name`` depends on (module docstring); ``slots`` None: the key of
    its family (the same step with any slots, :mod:`mmplan.compile.family`)."""
    here = Path(__file__).parent
    scene = Path(__file__).parents[2] / "scene"
    parts = [
        robot_fingerprint(robot),
        name,
        settings.model_dump_json(exclude=NOT_IN_STEP),
        repr(None if slots is None else slots.kinds),
        repr(ground),
        source_fingerprint([*python_files(here), *python_files(scene), cg.__file__]),
        repr(FLAGS),
    ]
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()[:24]


@dataclass(frozen=True)
class Loaded:
    """Compiled functions and the slots of their library (the scene's, or a family member's
    with more slots of each kind, or fewer of some: :mod:`.active`)."""

    functions: list[ca.Function]
    slots: Slots


class _NotBuiltError(Exception):
    """Raised instead of building: only a library already on disk is wanted."""


def _on_disk() -> list[ca.Function]:
    raise _NotBuiltError


def functions(
    names: Sequence[str],
    robot: Any,
    settings: Any,
    slots: Slots | None,
    ground: Any,
    build: Callable[[], Sequence[ca.Function]],
    exact: bool = False,
) -> Loaded | None:
    """The functions ``names`` (the step first) from a compiled library, which ``build`` (the
    tracker's symbolic model, with ``slots``) makes only when no library of the family serves
    (its own slots; else the fewest wider; else, unless ``exact``, the one with the most slots
    of a kind too few: the near obstacles in them, :mod:`.active`); None with ``codegen:
    false``, a scene without slots, no compiler (a notice) or a failed build."""
    if settings.codegen is False or slots is None:
        return None
    if cg.compiler() is None:
        cg.notice(f"{cg.no_compiler()}: the tracker's step runs on CasADi's virtual machine")
        return None
    key = disk_key(robot, names[0], settings, slots, ground)
    family = disk_key(robot, names[0], settings, None, ground)
    prefix = f"track_{names[0]}"
    found = [(key, slots.kinds), *cf.wider(FAMILY, family, slots.kinds)]
    found += [] if exact else cf.covering(FAMILY, family, slots.kinds)
    for other, kinds in found:
        if other in _FAILED:
            continue
        try:
            library = cg.compile_library(_on_disk, prefix, FLAGS, key=other)
        except _NotBuiltError:
            continue
        loaded = _load(names, library, other)
        if loaded is not None:
            return Loaded(loaded, Slots(tuple((str(k), int(n)) for k, n in kinds)))
    if key not in _FAILED:  # tried in this process: not again at every plan
        library = cg.compile_library(lambda: list(build()), prefix, FLAGS, cg.notice, key=key)
        loaded = _load(names, library, key)
        if loaded is not None:
            cf.remember(FAMILY, family, slots.kinds, key)
            return Loaded(loaded, slots)
    cg.notice(f"the compiled {names[0]} could not be built or loaded: it runs on CasADi's "
              "virtual machine")  # fmt: skip
    return None


def _load(names: Sequence[str], library: str | None, key: str) -> list[ca.Function] | None:
    """The functions from ``library``; None (the key not tried again in this process) when
    it is missing or unreadable (another machine's, damaged)."""
    try:
        if library is not None:
            return cg.load(names, library)
    except RuntimeError:
        pass
    _FAILED.add(key)
    return None


#: File-name prefix of the family lists (:mod:`mmplan.compile.family`).
FAMILY = "track_family"
#: Keys whose library failed to build or load in this process.
_FAILED: set[str] = set()
