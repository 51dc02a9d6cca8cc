"""Time-series figures of a plan, as [PajakPajak] and [Pajak] print them.

Each function returns a :class:`RenderedFigure`, or None when the plan lacks the data
(e.g. no obstacles, no efforts). :func:`time_figures` collects all that apply.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from mmplan.report.figure_data import FigureData
from mmplan.report.figure_kit import (
    RenderedFigure,
    legend_outside,
    limit_line,
    log_y,
    mean_normalized,
    new_figure,
    render,
)
from mmplan.report.palette import obstacle_color

#: Units of further trajectory columns ([JaniakTchon]'s platform controls: drive speed,
#: steering rate).
EXTRA_UNITS = {"u1": "m/s", "u2": "rad/s"}


def clearance_figure(ctx: FigureData) -> RenderedFigure | None:
    """Minimal robot-obstacle distance over time with neighbourhoods ([PajakPajak] Figs. 3, 8)."""
    if not ctx.obstacles or not np.isfinite(ctx.clearance).any():
        return None
    fig, ax = new_figure()
    t = ctx.t_dec
    for j, view in enumerate(ctx.obstacles):
        color = obstacle_color(j)
        ax.plot(t, ctx.clearance[:, j], color=color, label=f"obstacle {view.label}")
        if view.influence is not None:
            ax.axhline(ctx.margin + view.influence, color=color, linestyle="--", lw=1)
    if ctx.margin > 0:
        ax.axhline(
            ctx.margin, color="0.4", linestyle=":", lw=1, label=f"enlargement {ctx.margin} m"
        )
    limit_line(ax, 0.0, "contact")
    ax.set_xlabel(ctx.t_label)
    ax.set_ylabel("distance [m]")
    legend_outside(ax)
    lowest = float(np.nanmin(ctx.clearance))
    return render(
        fig,
        "clearance",
        "Minimal distance between robot and obstacles",
        "Exact distance from the robot's collision points to each original obstacle; dashed "
        "lines: influence neighbourhoods (enlargement + influence) as in [PajakPajak] Figs. 3 "
        "and 8. "
        f"Minimum {lowest:.4f} m.",
    )


def joints_figure(ctx: FigureData) -> RenderedFigure | None:
    """Mean-normalized arm joint angles with their limits at +-0.5 ([PajakPajak] Figs. 4, 9)."""
    if not ctx.arm_indices:
        return None
    values = ctx.plan.q[:, list(ctx.arm_indices)]
    norm, by_limits = mean_normalized(values, ctx.joint_min, ctx.joint_max)
    fig, ax = new_figure()
    for k, name in enumerate(ctx.arm_coordinates):
        ax.plot(ctx.plan.t, norm[:, k], label=name + ("" if by_limits[k] else " (by range)"))
    limit_line(ax, 0.5)
    limit_line(ax, -0.5, "limits")
    ax.set_xlabel(ctx.t_label)
    ax.set_ylabel("normalized angle [-]")
    legend_outside(ax)
    worst = float(np.max(np.abs(norm[:, by_limits]))) if by_limits.any() else float("nan")
    return render(
        fig,
        "joints",
        "Normalized arm joint angles",
        "(q - (q_min + q_max)/2) / (q_max - q_min): limits at +-0.5 (dashed red), as in "
        f"[PajakPajak] Figs. 4 and 9. Largest |normalized angle| {worst:.3f}.",
    )


def manipulability_figure(ctx: FigureData) -> RenderedFigure:
    """Arm manipulability mu(q) = sqrt(det(J_a J_a^T)) over time ([PajakPajak] Figs. 5, 10)."""
    fig, ax = new_figure()
    ax.plot(ctx.t_dec, ctx.manipulability, color="tab:purple")
    ax.set_xlabel(ctx.t_label)
    ax.set_ylabel(f"manipulability [{ctx.manipulability_unit}]")
    mu = ctx.manipulability
    return render(
        fig,
        "manipulability",
        "Arm manipulability",
        f"Yoshikawa measure of the arm, recomputed from q: start {mu[0]:.5f}, "
        f"end {mu[-1]:.5f}, min {np.min(mu):.5f} ([PajakPajak] Figs. 5 and 10).",
    )


def _torque_figure(ctx: FigureData, arm: bool) -> RenderedFigure | None:
    plan = ctx.plan
    if plan.tau is None:
        return None
    chosen = [i for i, a in enumerate(plan.actuators) if (a in ctx.arm_coordinates) == arm]
    if not chosen:
        return None
    lookup = {a: i for i, a in enumerate(ctx.actuators)}
    lo = np.array(
        [
            ctx.torque_min[lookup[plan.actuators[i]]] if plan.actuators[i] in lookup else -np.inf
            for i in chosen
        ]
    )
    hi = np.array(
        [
            ctx.torque_max[lookup[plan.actuators[i]]] if plan.actuators[i] in lookup else np.inf
            for i in chosen
        ]
    )
    norm, by_limits = mean_normalized(plan.tau[:, chosen], lo, hi)
    fig, ax = new_figure()
    for k, i in enumerate(chosen):
        suffix = "" if by_limits[k] else " (no limit: by range)"
        unit = ctx.effort_units[plan.actuators[i]]
        ax.plot(plan.t, norm[:, k], label=f"{plan.actuators[i]} [{unit}]{suffix}")
    if by_limits.any():
        limit_line(ax, 0.5)
        limit_line(ax, -0.5, "limits")
    ax.set_xlabel(ctx.t_label)
    ax.set_ylabel("normalized effort [-]")
    legend_outside(ax)
    part = "arm joint" if arm else "wheel"
    worst = float(np.max(np.abs(norm[:, by_limits]))) if by_limits.any() else float("nan")
    return render(
        fig,
        "torques_arm" if arm else "torques_wheels",
        f"Normalized {part} torques",
        f"Mean-normalized {part} efforts, limits at +-0.5 ([PajakPajak] Figs. 6-7, 11-12; "
        "[Pajak] Fig. 5). "
        f"Largest |normalized torque| within limits columns: {worst:.3f} (> 0.5 is a violation).",
    )


def wheel_torques_figure(ctx: FigureData) -> RenderedFigure | None:
    """Platform actuator efforts, mean-normalized with limits."""
    return _torque_figure(ctx, arm=False)


def arm_torques_figure(ctx: FigureData) -> RenderedFigure | None:
    """Arm joint efforts, mean-normalized with limits."""
    return _torque_figure(ctx, arm=True)


def virtual_control_figure(ctx: FigureData) -> RenderedFigure | None:
    """Virtual control u(t) ([PajakPajak] eq. 21, [Pajak] Fig. 7)."""
    if ctx.plan.u is None:
        return None
    fig, ax = new_figure(height=3.0)
    ax.plot(ctx.plan.t, ctx.plan.u, color="tab:green")
    ax.set_ylim(-0.05, 1.05)
    ax.set_xlabel(ctx.t_label)
    ax.set_ylabel("u [-]")
    return render(
        fig,
        "virtual_control",
        "Virtual control u(t)",
        "Scaling of the feedback that keeps the efforts inside the safety zone "
        "([PajakPajak] eq. (21), [Pajak] Fig. 7): 1 full speed, 0 the motion held back.",
    )


def extra_columns_figure(ctx: FigureData) -> RenderedFigure | None:
    """Further trajectory columns (e.g. platform controls u1, u2 of [JaniakTchon])."""
    extra = {k: v for k, v in ctx.plan.extra.items() if np.isfinite(v).any()}
    if not extra:
        return None
    fig, ax = new_figure(height=3.0)
    units = {EXTRA_UNITS.get(name, "-") for name in extra}
    for name, values in extra.items():
        ax.plot(ctx.plan.t, values, label=f"{name} [{EXTRA_UNITS.get(name, '-')}]")
    ax.set_xlabel(ctx.t_label)
    ax.set_ylabel(f"control [{', '.join(sorted(units))}]")
    legend_outside(ax)
    cited = " ([JaniakTchon] eq. (16): u1 drive speed, u2 steering rate)" if "u1" in extra else ""
    return render(
        fig,
        "extra_columns",
        "Further controls",
        f"Columns {', '.join(extra)} of trajectory.csv over time{cited}.",
    )


def task_error_figure(ctx: FigureData) -> RenderedFigure | None:
    """Task error over time (tracking error for paths, distance to goal for reach tasks)."""
    if ctx.task_error is None:
        return None
    fig, ax = new_figure(height=3.2)
    err = np.maximum(ctx.task_error, 1e-12)
    ax.plot(ctx.plan.t, err, color="tab:blue")
    log_y(ax)
    limit_line(ax, ctx.tolerance, f"tolerance {ctx.tolerance:g} m")
    ax.set_xlabel(ctx.t_label)
    ax.set_ylabel("error [m]")
    summary = ctx.plan.summary
    reach = summary.get("duration_s")
    if isinstance(reach, int | float) and not isinstance(reach, bool):
        ax.axvline(float(reach), color="0.3", linestyle=":", lw=1,
                   label=f"reach {'time' if ctx.timed else 'at'} {float(reach):.4g}"
                   + (" s" if ctx.timed else ""))
    legend_outside(ax)
    if ctx.task_kind == "reach":
        title, what = "Distance to the goal", "|k(q) - p_f|, the task of [PajakPajak] eq. (2)"
    elif ctx.task_kind == "segment":
        title = "Distance to the segment"
        what = "distance of the tool to the segment ([Nagatani] s.5.1)"
    else:
        title, what = "Tracking error", "|k(q(t)) - X_d(t)| ([AbdessemedDjebrani] s.2, s.3)"
    return render(
        fig, "task_error", title,
        f"{what} over time, log scale; dotted: the reach time (from then on within the "
        f"tolerance); final {ctx.task_error[-1]:.3g} m at the end, "
        f"{'t' if ctx.timed else 's'} = {ctx.plan.t[-1]:.4g}{' s' if ctx.timed else ''}.",
    )


#: A time-series figure: drawn from the figure data, or None without its data.
TimeFigure = Callable[[FigureData], RenderedFigure | None]

TIME_FIGURES: tuple[TimeFigure, ...] = (
    clearance_figure,
    joints_figure,
    manipulability_figure,
    wheel_torques_figure,
    arm_torques_figure,
    virtual_control_figure,
    extra_columns_figure,
    task_error_figure,
)


def time_figures(ctx: FigureData) -> list[RenderedFigure]:
    """Every time-series figure the plan has data for, in report order."""
    return [f for f in (make(ctx) for make in TIME_FIGURES) if f is not None]
