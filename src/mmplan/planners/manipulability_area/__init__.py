"""Base path keeping manipulability ([Nagatani]; docs/manipulability_area.md).

Data flow: :mod:`.settings` -> manipulability layers on a grid (:mod:`.grid`; the arm's IK:
closed form or numeric, :mod:`.arms`) -> base path (:mod:`.path`) -> trajectory and result
(:mod:`.result`), run by :mod:`.planner`.
"""

from typing import TYPE_CHECKING

from mmplan._lazy import lazy_exports

if TYPE_CHECKING:
    from mmplan.planners.manipulability_area.planner import ManipulabilityArea
    from mmplan.planners.manipulability_area.settings import ManipulabilityAreaSettings

__all__ = ["ManipulabilityArea", "ManipulabilityAreaSettings"]

__getattr__, __dir__ = lazy_exports(
    __name__,
    {"ManipulabilityArea": ".planner", "ManipulabilityAreaSettings": ".settings"},
)
