"""Path trackers of [AbdessemedDjebrani] (docs/tracking.md): weighted pseudoinverse and
virtual impedance.

Data flow: :mod:`.settings` -> models (:mod:`.pseudoinverse`, :mod:`.impedance`, with
:mod:`.potentials`) -> compiled step and rollout (:mod:`.rollout`) -> result (:mod:`.result`)
-> planners (:mod:`.planner`).
"""

from typing import TYPE_CHECKING

from mmplan._lazy import lazy_exports

if TYPE_CHECKING:
    from mmplan.planners.tracking.planner import ImpedancePlanner, PseudoinversePlanner
    from mmplan.planners.tracking.settings import (
        ImpedanceSettings,
        PseudoinverseSettings,
        TrackingSettings,
    )

__all__ = [
    "ImpedancePlanner",
    "ImpedanceSettings",
    "PseudoinversePlanner",
    "PseudoinverseSettings",
    "TrackingSettings",
]

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "ImpedancePlanner": ".planner",
        "PseudoinversePlanner": ".planner",
        "ImpedanceSettings": ".settings",
        "PseudoinverseSettings": ".settings",
        "TrackingSettings": ".settings",
    },
)
