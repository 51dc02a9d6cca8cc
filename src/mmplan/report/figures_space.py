"""Spatial figures: end-effector and platform paths seen from above, with the obstacles.

Mirrors [PajakPajak] Fig. 2, [Pajak] Fig. 6 and [AbdessemedDjebrani] Figs. 4, 10: the paths in
the x-y plane, obstacle outlines (horizontal cross-sections of their superellipsoid models), the
influence neighbourhoods dashed, and a few snapshots of the robot's links.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from mmplan.report.context import ReportContext
from mmplan.report.figure_kit import DPI, RenderedFigure, limit_line, new_figure, render
from mmplan.report.shapes import top_outline
from mmplan.task import DrawSegment, TrackPath

SNAPSHOTS = 6


def link_segments(ctx: ReportContext, q: np.ndarray) -> list[np.ndarray]:
    """Segments (2, 3) between every drawable body origin and its parent, plus the tool."""
    robot = ctx.robot
    bodies = robot.body_positions(q)
    segments = []
    for joint in robot.tree.joints:
        if joint.parent in bodies and joint.child in bodies:
            segments.append(np.array([bodies[joint.parent], bodies[joint.child]]))
    ee_body = robot.end_effector.body
    if ee_body in bodies:
        segments.append(np.array([bodies[ee_body], robot.ee_position(q)]))
    return segments


def platform_path(ctx: ReportContext) -> np.ndarray:
    """Platform reference point (x, y) over the decimated samples (K, 2)."""
    robot = ctx.robot
    q_dec = ctx.plan.q[ctx.index.astype(int)]
    if "platform" in robot.tree.bodies:
        return np.array([robot.body_positions(q)["platform"][:2] for q in q_dec])
    return np.asarray(q_dec[:, :2], dtype=float)


def reference_path(ctx: ReportContext) -> np.ndarray | None:
    """Desired end-effector positions at the decimated samples (K, 3), None for reach tasks."""
    task = ctx.task
    t = ctx.t_dec
    if isinstance(task, TrackPath):
        return np.array([task.position(float(s)) for s in t])
    if isinstance(task, DrawSegment):
        return np.array([task.point(float(np.clip(s, 0.0, 1.0))) for s in t])
    return None


def top_view_figure(ctx: ReportContext) -> RenderedFigure:
    """Paths of the end effector and the platform from above with obstacle outlines."""
    plan = ctx.plan
    fig, ax = new_figure(width=6.4, height=6.0)
    for j, view in enumerate(ctx.obstacles):
        outline = top_outline(view.obstacle.superellipsoid())
        color = f"C{j % 10}"
        ax.fill(outline[:, 0], outline[:, 1], color=color, alpha=0.35, lw=0)
        ax.plot(outline[:, 0], outline[:, 1], color=color, lw=1.2, label=f"obstacle {view.label}")
        if view.influence is not None:
            grown = view.obstacle.enlarged(ctx.margin + view.influence).superellipsoid()
            ring = top_outline(grown)
            ax.plot(ring[:, 0], ring[:, 1], color=color, lw=0.8, linestyle="--")
    snaps = np.unique(np.linspace(0, plan.samples - 1, SNAPSHOTS).round().astype(int))
    for k, i in enumerate(snaps):
        for seg in link_segments(ctx, plan.q[i]):
            ax.plot(seg[:, 0], seg[:, 1], color="0.25", lw=1.0, alpha=0.35 + 0.65 * k / len(snaps))
    base = platform_path(ctx)
    ax.plot(base[:, 0], base[:, 1], color="tab:gray", lw=1.5, label="platform")
    ax.plot(plan.ee[:, 0], plan.ee[:, 1], color="tab:orange", lw=1.8, label="end effector")
    ax.plot(*plan.ee[0, :2], "o", color="tab:orange", ms=5)
    reference = reference_path(ctx)
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
        ax.plot(goal[0], goal[1], "*", color="tab:green", ms=12, label="goal")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(fontsize=8, loc="best")
    return render(
        fig,
        "top_view",
        "Paths seen from above",
        "End-effector and platform paths in the x-y plane with obstacle cross-sections "
        "(filled) and influence neighbourhoods (dashed); grey: the links at "
        f"{len(snaps)} instants ([PajakPajak] Fig. 2, [Pajak] Fig. 6).",
    )


def coordinate_bounds(ctx: ReportContext) -> dict[str, tuple[float, float]]:
    """Planner-setting state bounds, ``bounds: [{coordinate, min, max}]`` ([JaniakTchon])."""
    planner = ctx.plan.scenario.get("planner") or {}
    found: dict[str, tuple[float, float]] = {}
    for item in planner.get("bounds") or []:
        if isinstance(item, dict) and {"coordinate", "min", "max"} <= set(item):
            found[str(item["coordinate"])] = (float(item["min"]), float(item["max"]))
    return found


def platform_figure(ctx: ReportContext) -> RenderedFigure:
    """Platform coordinates over time, one panel each, with planner bounds.

    As in [JaniakTchon] and [AbdessemedDjebrani] Fig. 8.
    """
    robot, plan = ctx.robot, ctx.plan
    names = robot.platform_coordinates
    bounds = coordinate_bounds(ctx)
    cols = 2 if len(names) > 1 else 1
    rows = -(-len(names) // cols)
    fig = Figure(figsize=(7.0, 1.9 * rows + 0.5), dpi=DPI, layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False, sharex=True).ravel()
    for ax, name in zip(axes, names, strict=False):
        ax.plot(plan.t, plan.q[:, robot.index(name)], color="tab:blue", lw=1.2)
        if name in bounds:
            for value in bounds[name]:
                limit_line(ax, value)
        ax.set_ylabel(name)
        ax.grid(True, alpha=0.3)
    for ax in axes[len(names) :]:
        ax.set_visible(False)
    for ax in axes[max(0, len(names) - cols) : len(names)]:
        ax.set_xlabel("t [s]")
    text = "; ".join(f"{k} in [{lo:.4g}, {hi:.4g}]" for k, (lo, hi) in bounds.items())
    return render(
        fig,
        "platform",
        "Platform coordinates",
        "Platform coordinates over time"
        + (f"; dashed red: planner bounds {text}." if bounds else "."),
    )
