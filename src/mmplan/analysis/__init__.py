"""Studies of a finished plan that the CLI and the report run after planning (not planners).

:func:`analyse` adds the studies a problem's settings ask for to a plan result; today the
tip-vibration study of :mod:`mmplan.analysis.vibration` (the claim of [Pajak] s.4, tested by
the experiment of s.5.3, Figs. 8-9), requested by a method's ``vibration`` setting (the
extended-Jacobian planner's, on by default).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from mmplan.problem import Problem
from mmplan.trajectory import PlanResult

__all__ = ["MAX_STUDY_DURATION_S", "analyse"]

#: Longest trajectory [s] the studies sample uniformly (a diverged plan may span far more).
MAX_STUDY_DURATION_S = 3600.0


def analyse(result: PlanResult, problem: Problem) -> PlanResult:
    """``result`` with the studies its problem's settings request added (info, artifacts).

    The studies never change the trajectory or the status, and their time is not part of
    ``compute_time_s``.
    """
    if not getattr(problem.settings, "vibration", False):
        return result
    from mmplan.analysis.vibration import with_vibration

    t = result.trajectory.t
    if t.size < 2 or not np.all(np.isfinite(t)) or t[-1] - t[0] > MAX_STUDY_DURATION_S:
        # A diverged plan can hold absurd times (3e49 s measured): the study would need an
        # absurd uniform grid. Say so instead of failing.
        note = f"vibration study skipped: trajectory spans {t[-1] - t[0]:.3g} s" if t.size else ""
        return replace(result, info={**result.info, "analysis": note or "vibration study skipped"})
    return with_vibration(result, problem.robot)
