"""Endogenous configuration space planner ([JaniakTchon]; docs/endogenous.md).

Data flow: :mod:`.settings` -> :mod:`.checks` -> model (:mod:`.model`, cached by
:mod:`.cache`) -> theta-iteration (:mod:`.planner`) -> trajectory (:mod:`.output`).
"""

from typing import TYPE_CHECKING

from mmplan._lazy import lazy_exports

if TYPE_CHECKING:
    from mmplan.planners.endogenous.planner import EndogenousPlanner
    from mmplan.planners.endogenous.settings import BoundSetting, EndogenousSettings

__all__ = ["BoundSetting", "EndogenousPlanner", "EndogenousSettings"]

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "EndogenousPlanner": ".planner",
        "BoundSetting": ".settings",
        "EndogenousSettings": ".settings",
    },
)
