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
from pathlib import Path
from typing import Any

import casadi as ca

from mmplan.compile import codegen as cg
from mmplan.compile.fingerprint import python_files, robot_fingerprint, source_fingerprint
from mmplan.planners.tracking.slots import Slots

#: C flags of a step (measured on diffdrive3-track's step: see docs/tracking.md).
FLAGS = ("-O1",)
#: Settings that do not enter a step's expressions (stop rules, horizon, this switch).
NOT_IN_STEP = {"t_max", "min_singular_value", "max_error", "settle_time", "stop_on_collision",
               "codegen", "method"}  # fmt: skip


def disk_key(robot: Any, name: str, settings: Any, slots: Slots, ground: Any) -> str:
    """What a compiled step ``name`` depends on (module docstring)."""
    here = Path(__file__).parent
    scene = Path(__file__).parents[2] / "scene"
    parts = [
        robot_fingerprint(robot),
        name,
        settings.model_dump_json(exclude=NOT_IN_STEP),
        repr(slots.kinds),
        repr(ground),
        source_fingerprint([*python_files(here), *python_files(scene), cg.__file__]),
        repr(FLAGS),
    ]
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()[:24]


def functions(
    names: Sequence[str],
    robot: Any,
    settings: Any,
    slots: Slots | None,
    ground: Any,
    build: Callable[[], Sequence[ca.Function]],
) -> list[ca.Function] | None:
    """The functions ``names`` (the step first) from their compiled library, which ``build``
    (the tracker's symbolic model) makes only when it is not on disk; None with
    ``codegen: false``, a scene without slots, no compiler (a notice) or a failed build."""
    if settings.codegen is False or slots is None:
        return None
    if cg.compiler() is None:
        cg.notice(f"{cg.no_compiler()}: the tracker's step runs on CasADi's virtual machine")
        return None
    key = disk_key(robot, names[0], settings, slots, ground)
    if key in _FAILED:  # tried in this process: not again at every plan
        return None
    library = cg.compile_library(
        lambda: list(build()), f"track_{names[0]}", FLAGS, cg.notice, key=key
    )  # fmt: skip
    try:
        if library is not None:
            return cg.load(names, library)
    except RuntimeError:  # unreadable (another machine's, damaged): the VM, said once
        pass
    _FAILED.add(key)
    cg.notice(f"the compiled {names[0]} could not be built or loaded: it runs on CasADi's "
              "virtual machine")  # fmt: skip
    return None


#: Keys whose library failed to build or load in this process.
_FAILED: set[str] = set()
