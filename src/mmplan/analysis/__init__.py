"""Studies of a finished plan that the CLI and the report run after planning (not planners).

:func:`analyse` adds the studies a problem's settings ask for to a plan result; today the
tip-vibration study of :mod:`mmplan.analysis.vibration` (the claim of [Pajak] s.4, tested by
the experiment of s.5.3, Figs. 8-9), requested by a method's ``vibration`` setting (the
extended-Jacobian planner's, on by default).
"""

from __future__ import annotations

from mmplan.problem import Problem
from mmplan.trajectory import PlanResult

__all__ = ["analyse"]


def analyse(result: PlanResult, problem: Problem) -> PlanResult:
    """``result`` with the studies its problem's settings request added (info, artifacts).

    The studies never change the trajectory or the status, and their time is not part of
    ``compute_time_s``.
    """
    if getattr(problem.settings, "vibration", False):
        from mmplan.analysis.vibration import with_vibration

        return with_vibration(result, problem.robot)
    return result
