"""The report's opening: what happened, in plain language, and the margin to every limit.

Everything here is a number of the plan read with its meaning: the reach time (the first time
the end effector stays within the tolerance, T(tol) of summary.json, recomputed by the
checker) is named apart from the trajectory's end (its last sample); clearances are to the
original obstacles; a margin is how far the plan stays from a limit at its closest (negative:
the limit is broken). Joint and effort margins are computed here from trajectory.csv and the
scenario's limits, the other numbers are summary.json's (the independent checker's).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from mmplan.report.context import ReportContext
from mmplan.report.summary_rows import LimitRow, Overview
from mmplan.robot import Robot
from mmplan.robot.tree import JointKind

#: What each status means for the reader (summary.json ``status``).
STATUS_TEXT = {
    "stalled": "the planner stopped because the end effector made no more progress",
    "diverged": "the planner stopped because the motion diverged",
    "infeasible": "the planner stopped because no motion within the limits was found",
    "timeout": "the planner ran out of time (planner.t_max)",
}
#: Relative slack of the checker's rate limits (mmplan.verify.rates.RATE_REL_TOL).
RATE_SLACK = 1e-6
RATE_UNITS = {"platform_speed": ("Platform speed", "m/s", "peak_platform_speed_mps"),
              "platform_yaw_rate": ("Platform yaw rate", "rad/s", "peak_platform_yaw_rate_radps"),
              "platform_acceleration": ("Platform acceleration", "m/s^2",
                                        "peak_platform_acceleration_mps2"),
              "platform_yaw_acceleration": ("Platform yaw acceleration", "rad/s^2",
                                            "peak_platform_yaw_acceleration_radps2")}


def fmt(value: float | None, unit: str = "", digits: int = 4) -> str:
    """``value`` with ``digits`` significant digits and its unit; ``-`` for None or NaN."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "–"
    return f"{value:.{digits}g} {unit}".strip()


def _number(summary: Mapping[str, Any], key: str) -> float | None:
    value = summary.get(key)
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return float(value)


def coordinate_unit(robot: Robot, coordinate: str) -> str:
    """``m`` for a prismatic coordinate or a platform position, else ``rad``."""
    for joint in robot.tree.joints:
        if joint.coordinate == coordinate:
            return "m" if joint.kind is JointKind.PRISMATIC else "rad"
    return "rad"


def effort_unit(robot: Robot, actuator: str) -> str:
    """N m for torques (arm revolute joints, wheels, yaw, steering), N for forces."""
    if actuator in robot.arm_coordinates:
        return "N" if coordinate_unit(robot, actuator) == "m" else "N m"
    return "N" if actuator.startswith(("force", "drive")) else "N m"


def at(ctx: ReportContext, value: float | None) -> str:
    """An instant of the plan: ``t = 13.78 s``, or ``s = 0.5`` for a segment's parameter."""
    if value is None:
        return "never"
    return f"t = {value:.4g} s" if ctx.timed else f"s = {value:.4g}"


def _headline(ctx: ReportContext, summary: Mapping[str, Any], t_end: float) -> tuple[bool, str]:
    status = str(summary.get("status", "unknown"))
    tol = ctx.tolerance
    reach = _number(summary, "duration_s")
    final = _number(summary, "final_error_m")
    goal = {"reach": "reached the goal", "path": "tracked the path",
            "segment": "drew the segment"}.get(ctx.task_kind, "completed its task")
    if status == "reached":
        text = f"The end effector {goal}: it is within the {fmt(tol * 1e3)} mm tolerance"
        text += f" from {at(ctx, reach)} on" if reach is not None else ""
        text += f" (the reach time). The {'trajectory' if ctx.timed else 'path'} ends at "
        text += f"{at(ctx, t_end)} with an error of "
        text += f"{fmt(None if final is None else final * 1e3, 'mm', 3)}."
        if not ctx.timed:
            text += (" The plan is a path without timing: its parameter s runs from 0 to 1 "
                     "along the segment ([Nagatani] s.4).")
        return True, text
    why = STATUS_TEXT.get(status, f"the planner reported {status!r}")
    text = (f"The end effector did not complete its task: {why}. The trajectory ends at "
            f"{at(ctx, t_end)}, {fmt(final, 'm')} from the target (tolerance {tol:g} m).")
    message = summary.get("message")
    return False, text + (f" Planner: {message}" if message else "")


def _facts(ctx: ReportContext, summary: Mapping[str, Any], t_end: float
           ) -> list[tuple[str, str, str]]:
    compute = _number(summary, "compute_time_s")
    ratio = ""
    if compute and ctx.timed and t_end > compute:
        ratio = f" ({t_end / compute:.0f}x faster than the motion)"
    what = "Reach time T(tol)" if ctx.timed else "Within the tolerance from"
    return [
        (f"{what}: from then on within the tolerance", at(ctx, _number(summary, "duration_s")),
         "fact.reach_time"),
        (f"{'Trajectory' if ctx.timed else 'Path'} end (last sample)", at(ctx, t_end),
         "fact.t_end"),
        ("T(1 cm) / T(1 mm)", f"{at(ctx, _number(summary, 'duration_1cm_s'))} / "
         f"{at(ctx, _number(summary, 'duration_1mm_s'))}", "fact.t_1cm_1mm"),
        ("Final error", fmt(_number(summary, "final_error_m"), "m"), "fact.final_error"),
        ("Compute time", fmt(compute, "s", 3) + ratio, "fact.compute_time"),
    ]


def _clearance_row(ctx: ReportContext, summary: Mapping[str, Any]) -> list[LimitRow]:
    value = _number(summary, "min_clearance_m")
    if not ctx.obstacles or value is None:
        return []
    where = ""
    if np.isfinite(ctx.clearance).any():
        k, j = np.unravel_index(int(np.nanargmin(ctx.clearance)), ctx.clearance.shape)
        where = f" (obstacle {ctx.obstacles[j].label}, {at(ctx, float(ctx.t_dec[k]))})"
    margin = fmt(value, "m")
    if ctx.margin > 0:
        margin += (f"; {fmt(value - ctx.margin, 'm')} outside the planner's {ctx.margin:g} m "
                   "enlargement")
    return [LimitRow("limit.clearance", "Clearance to the obstacles", fmt(value, "m") + where,
                     ">= 0 m (contact)", margin, value >= 0)]


def _range_rows(ctx: ReportContext) -> list[LimitRow]:
    """Arm joints (rad or m) and actuator efforts (N m or N): closest approach to each limit."""
    robot, plan = ctx.robot, ctx.plan
    lim = robot.limits
    rows = []
    for k, name in enumerate(robot.arm_coordinates):
        unit = coordinate_unit(robot, name)
        values = plan.q[:, robot.index(name)]
        rows.append(_range_row(ctx, f"limit.joint.{name}", f"Joint {name}", values,
                               float(lim.joint_min[k]), float(lim.joint_max[k]), unit))
    if plan.tau is not None:
        lookup = {a: i for i, a in enumerate(robot.actuators)}
        for i, name in enumerate(plan.actuators):
            if name in lookup:
                j = lookup[name]
                rows.append(_range_row(ctx, f"limit.effort.{name}", f"Effort {name}",
                                       plan.tau[:, i], float(lim.torque_min[j]),
                                       float(lim.torque_max[j]), effort_unit(robot, name)))
    return rows


def _range_row(ctx: ReportContext, key: str, what: str, values: np.ndarray, lo: float,
               hi: float, unit: str) -> LimitRow:
    used = f"[{values.min():.3g}, {values.max():.3g}] {unit}"
    if not (math.isfinite(lo) or math.isfinite(hi)):
        return LimitRow(key, what, used, "none", "–", None)
    gap = np.minimum(values - lo, hi - values)
    k = int(np.argmin(gap))
    limit = f"[{lo:.4g}, {hi:.4g}] {unit}"
    share = ""
    if math.isfinite(lo) and math.isfinite(hi) and hi > lo:
        share = f" ({100 * gap[k] / (hi - lo):.0f} % of the range)"
    return LimitRow(key, what, used, limit,
                    f"{gap[k]:.3g} {unit}{share} at {at(ctx, float(ctx.plan.t[k]))}",
                    bool(gap[k] >= 0))


def _rate_rows(ctx: ReportContext, summary: Mapping[str, Any]) -> list[LimitRow]:
    """Velocity and acceleration limits from summary.json (``limit_margins``, peaks)."""
    margins = summary.get("limit_margins")
    if not isinstance(margins, Mapping):
        return []
    rows = []
    for key, margin in margins.items():
        if not isinstance(margin, int | float):
            continue
        kind, _, name = str(key).partition(".")
        if key in RATE_UNITS:
            what, unit, peak_key = RATE_UNITS[key]
            peak = _number(summary, peak_key)
        elif kind in ("velocity", "acceleration") and name:
            base = coordinate_unit(ctx.robot, name) if name in ctx.robot.coordinates else "rad"
            unit = f"{base}/s" if kind == "velocity" else f"{base}/s^2"
            what = f"{'Speed' if kind == 'velocity' else 'Acceleration'} of {name}"
            peaks = summary.get(f"peak_{kind}")
            peak = float(peaks[name]) if isinstance(peaks, Mapping) and name in peaks else None
        else:
            continue
        bound = None if peak is None else peak + float(margin)
        slack = RATE_SLACK * abs(bound) if bound is not None else 0.0  # the checker's
        shown = fmt(float(margin), unit)
        if -slack <= float(margin) < 0:
            shown = f"0 {unit} (at the limit)"
        rows.append(LimitRow(f"limit.rate.{key}", what, "peak " + fmt(peak, unit),
                             "<= " + fmt(bound, unit), shown, float(margin) >= -slack))
    return rows


def _pfaffian_row(ctx: ReportContext, summary: Mapping[str, Any]) -> list[LimitRow]:
    """The wheels' rolling constraints A(q) dq = 0 (none for an omnidirectional base)."""
    from mmplan.verify.check import PFAFFIAN_TOL

    value = _number(summary, "max_pfaffian_residual")
    if value is None or ctx.robot.h == 0:
        return []
    return [LimitRow("limit.pfaffian", "Wheels roll without slipping: max |A(q) dq|",
                     fmt(value, "m/s", 3), f"<= {PFAFFIAN_TOL:g} m/s (checker)",
                     fmt(PFAFFIAN_TOL - value, "m/s", 3), value <= PFAFFIAN_TOL)]


def overview(ctx: ReportContext) -> Overview:
    """The report's opening for ``ctx``'s plan (see the module docstring)."""
    summary = ctx.plan.summary
    t_end = float(ctx.plan.t[-1])
    reached, headline = _headline(ctx, summary, t_end)
    rows = _clearance_row(ctx, summary) + _range_rows(ctx) + _rate_rows(ctx, summary)
    rows += _pfaffian_row(ctx, summary)
    return Overview(reached, headline, _facts(ctx, summary, t_end), rows)
