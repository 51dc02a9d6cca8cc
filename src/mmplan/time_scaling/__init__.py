"""Time-optimal scaling of a path under effort, velocity and acceleration limits (:mod:`.topp`;
compiled passes in :mod:`.passes`; rate limits as constraints and verdicts in :mod:`.rates`): a
general tool, used by the extended-Jacobian planner's time mode and by every planner that
re-times its plan."""

from mmplan.time_scaling.rates import PathRates, RateModel, RateViolation
from mmplan.time_scaling.retime import Retimed, retime_path
from mmplan.time_scaling.topp import Scaling, reference_scaling, time_optimal_scaling

__all__ = [
    "PathRates",
    "RateModel",
    "RateViolation",
    "Retimed",
    "Scaling",
    "reference_scaling",
    "retime_path",
    "time_optimal_scaling",
]
