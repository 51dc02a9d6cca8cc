"""Spatial figures: end-effector and platform paths seen from above, with the obstacles.

Mirrors [PajakPajak] Fig. 2, [Pajak] Fig. 6 and [AbdessemedDjebrani] Figs. 4, 10: the paths in
the x-y plane, the obstacles' footprints in their true shapes (a box as its rectangle), the
planners' influence neighbourhoods dashed (their superellipsoid models enlarged by the margin
and the influence), and a few snapshots of the robot's links.
"""

from __future__ import annotations

from matplotlib.figure import Figure

from mmplan.report.figure_data import FigureData
from mmplan.report.figure_kit import (
    DPI,
    RenderedFigure,
    legend_outside,
    new_figure,
    render,
)
from mmplan.report.palette import EE_COLOR, GOAL_COLOR, PLATFORM_PATH_COLOR, obstacle_color


def top_view_figure(ctx: FigureData) -> RenderedFigure:
    """Paths of the end effector and the platform from above with obstacle outlines."""
    plan = ctx.plan
    fig, ax = new_figure(width=7.6, height=6.0)
    for j, view in enumerate(ctx.obstacles):
        outline = view.footprint
        color = obstacle_color(j)
        ax.fill(outline[:, 0], outline[:, 1], color=color, alpha=0.35, lw=0)
        ax.plot(outline[:, 0], outline[:, 1], color=color, lw=1.2, label=f"obstacle {view.label}")
        if view.neighbourhood is not None:
            ring = view.neighbourhood
            ax.plot(ring[:, 0], ring[:, 1], color=color, lw=0.8, linestyle="--")
    snaps = ctx.snapshots
    for k, links in enumerate(ctx.links):
        for seg in links:
            ax.plot(seg[:, 0], seg[:, 1], color="0.25", lw=1.0, alpha=0.35 + 0.65 * k / len(snaps))
    base = ctx.platform_path
    ax.plot(base[:, 0], base[:, 1], color=PLATFORM_PATH_COLOR, lw=1.5, label="platform")
    ax.plot(plan.ee[:, 0], plan.ee[:, 1], color=EE_COLOR, lw=1.8, label="end effector")
    ax.plot(*plan.ee[0, :2], "o", color=EE_COLOR, ms=5, label="start")
    reference = ctx.reference_path
    if reference is not None:
        ax.plot(
            reference[:, 0],
            reference[:, 1],
            color="black",
            lw=1.0,
            linestyle="--",
            label="reference path",
        )
    goal = (ctx.plan.scenario.get("goal") or {}).get("position")
    if goal is not None:
        ax.plot(goal[0], goal[1], "*", color=GOAL_COLOR, ms=12, label="goal")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    legend_outside(ax)
    return render(
        fig,
        "top_view",
        "Paths seen from above",
        "End-effector and platform paths in the x-y plane with the obstacles' footprints "
        "(filled) and the planner's influence neighbourhoods (dashed); grey: the links at "
        f"{len(snaps)} instants ([PajakPajak] Fig. 2, [Pajak] Fig. 6).",
    )


def coordinate_bounds(ctx: FigureData) -> dict[str, tuple[float, float]]:
    """Planner-setting state bounds, ``bounds: [{coordinate, min, max}]`` ([JaniakTchon])."""
    planner = ctx.plan.scenario.get("planner") or {}
    found: dict[str, tuple[float, float]] = {}
    for item in planner.get("bounds") or []:
        if isinstance(item, dict) and {"coordinate", "min", "max"} <= set(item):
            found[str(item["coordinate"])] = (float(item["min"]), float(item["max"]))
    return found


def platform_figure(ctx: FigureData) -> RenderedFigure:
    """Platform coordinates over time, a panel per unit, with planner bounds.

    As in [JaniakTchon] and [AbdessemedDjebrani] Fig. 8.
    """
    plan = ctx.plan
    bounds = coordinate_bounds(ctx)
    groups = ctx.platform_groups
    fig = Figure(figsize=(7.0, 1.7 * len(groups) + 0.6), dpi=DPI, layout=None)
    axes = fig.subplots(len(groups), 1, squeeze=False, sharex=True)[:, 0]
    for ax, (label, names) in zip(axes, groups, strict=True):
        for k, name in enumerate(names):
            color = f"C{k}"
            ax.plot(plan.t, plan.q[:, ctx.columns[name]], color=color, lw=1.2, label=name)
            for i, value in enumerate(bounds.get(name, ())):
                ax.axhline(value, color=color, linestyle="--", lw=1.0,
                           label=f"bound of {name}" if i == 0 else None)
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
        legend_outside(ax)
    axes[-1].set_xlabel(ctx.t_label)
    text = "; ".join(f"{k} in [{lo:.4g}, {hi:.4g}]" for k, (lo, hi) in bounds.items())
    return render(
        fig,
        "platform",
        "Platform coordinates",
        "Platform coordinates over time, grouped by unit (as in [JaniakTchon] s.III and "
        "[AbdessemedDjebrani] Fig. 8)"
        + (f"; dashed: planner bounds {text} ([JaniakTchon] s.III-B)." if bounds else "."),
    )
