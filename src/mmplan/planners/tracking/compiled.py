"""The trackers' control steps compiled to C, found again by what they are made of.

A step with the scene's obstacles as parameters (:mod:`.slots`) depends on the robot model,
the settings that enter its expressions, the obstacle kinds with their slot counts, the floor
and the code: that is the key of its library (:func:`disk_key`), so a moved, resized or new
obstacle of the same kinds, or another path, runs the same library, and a later process finds
it without generating the C source again (the model's expressions are still built: the
tracker's other functions need them). A scene with a shape without a parametric form keeps
its numbers built in and runs on CasADi's virtual machine (it would compile per scene).
"""

from __future__ import annotations

import hashlib
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


def disk_key(robot: Any, step: ca.Function, settings: Any, slots: Slots, ground: Any) -> str:
    """What a compiled step depends on (module docstring)."""
    here = Path(__file__).parent
    scene = Path(__file__).parents[2] / "scene"
    parts = [
        robot_fingerprint(robot),
        step.name(),
        settings.model_dump_json(exclude=NOT_IN_STEP),
        repr(slots.kinds),
        repr(ground),
        source_fingerprint([*python_files(here), *python_files(scene), cg.__file__]),
        repr(FLAGS),
    ]
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()[:24]


def native(
    step: ca.Function, robot: Any, settings: Any, slots: Slots | None, ground: Any
) -> tuple[ca.Function, str]:
    """The step compiled to C (cached) and ``"c"``; the step itself and ``"vm"`` with
    ``codegen: false``, a scene without slots, no compiler (a notice) or a failed build."""
    if settings.codegen is False or slots is None:
        return step, "vm"
    if cg.compiler() is None:
        cg.notice(f"{cg.no_compiler()}: the tracker's step runs on CasADi's virtual machine")
        return step, "vm"
    key = disk_key(robot, step, settings, slots, ground)
    library = cg.compile_library([step], f"track_{step.name()}", FLAGS, cg.notice, key=key)
    if library is None:
        return step, "vm"
    return cg.load([step.name()], library)[0], "c"
