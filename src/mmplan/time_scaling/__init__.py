"""Time-optimal scaling of a path under effort limits (:mod:`.topp`; compiled passes in
:mod:`.passes`): a general tool, used by the extended-Jacobian planner's time mode."""

from mmplan.time_scaling.topp import Scaling, reference_scaling, time_optimal_scaling

__all__ = ["Scaling", "reference_scaling", "time_optimal_scaling"]
