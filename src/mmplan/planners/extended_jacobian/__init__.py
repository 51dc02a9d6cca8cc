"""Extended-Jacobian planner ([PajakPajak], [Pajak]; docs/extended_jacobian.md).

Data flow, top to bottom: :mod:`.settings` -> :mod:`.checks` -> symbolic model
(:mod:`.structure`, :mod:`.criterion`, :mod:`.effort`, :mod:`.parameters` (the scene as
numbers), :mod:`.slots`, :mod:`.obstacles`, :mod:`.near_goal`, :mod:`.generator`) ->
compiled step (:mod:`.step`, :mod:`.functions`, :mod:`.compiled` (disk cache),
:mod:`.cache`) -> rollout (:mod:`.options`, :mod:`.torque`, :mod:`.chunks`, :mod:`.samples`,
:mod:`.rollout`) -> time scaling (:mod:`.time_scaling`) -> result (:mod:`.planner`);
:mod:`.online` is the same step for a control loop, :mod:`.replan` re-plans from a moving
state among moved obstacles.
"""

from typing import TYPE_CHECKING

from mmplan._lazy import lazy_exports

if TYPE_CHECKING:
    from mmplan.planners.extended_jacobian.online import OnlineGenerator
    from mmplan.planners.extended_jacobian.planner import ExtendedJacobian
    from mmplan.planners.extended_jacobian.replan import Replanner
    from mmplan.planners.extended_jacobian.settings import (
        ExtendedJacobianSettings,
        VirtualControlSettings,
    )

__all__ = [
    "ExtendedJacobian",
    "ExtendedJacobianSettings",
    "OnlineGenerator",
    "Replanner",
    "VirtualControlSettings",
]

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "ExtendedJacobian": ".planner",
        "ExtendedJacobianSettings": ".settings",
        "VirtualControlSettings": ".settings",
        "OnlineGenerator": ".online",
        "Replanner": ".replan",
    },
)
