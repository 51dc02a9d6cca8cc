"""Spatial figures: end-effector and platform paths seen from above, with the obstacles.

Mirrors [PajakPajak] Fig. 2, [Pajak] Fig. 6 and [AbdessemedDjebrani] Figs. 4, 10: the paths in
the x-y plane, the obstacles' footprints in their true shapes (a box as its rectangle), the
planners' influence neighbourhoods dashed (their superellipsoid models enlarged by the margin
and the influence), and a few snapshots of the robot's links.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from mmplan.report.context import ReportContext
from mmplan.report.figure_kit import (
    DPI,
    RenderedFigure,
    legend_outside,
    new_figure,
    render,
)
from mmplan.report.overview import coordinate_unit
from mmplan.report.palette import EE_COLOR, GOAL_COLOR, PLATFORM_PATH_COLOR, obstacle_color
from mmplan.report.shapes import footprint, top_outline
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
    fig, ax = new_figure(width=7.6, height=6.0)
    for j, view in enumerate(ctx.obstacles):
        outline = footprint(view.obstacle)
        color = obstacle_color(j)
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
    ax.plot(base[:, 0], base[:, 1], color=PLATFORM_PATH_COLOR, lw=1.5, label="platform")
    ax.plot(plan.ee[:, 0], plan.ee[:, 1], color=EE_COLOR, lw=1.8, label="end effector")
    ax.plot(*plan.ee[0, :2], "o", color=EE_COLOR, ms=5, label="start")
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


def coordinate_bounds(ctx: ReportContext) -> dict[str, tuple[float, float]]:
    """Planner-setting state bounds, ``bounds: [{coordinate, min, max}]`` ([JaniakTchon])."""
    planner = ctx.plan.scenario.get("planner") or {}
    found: dict[str, tuple[float, float]] = {}
    for item in planner.get("bounds") or []:
        if isinstance(item, dict) and {"coordinate", "min", "max"} <= set(item):
            found[str(item["coordinate"])] = (float(item["min"]), float(item["max"]))
    return found


def platform_groups(ctx: ReportContext) -> list[tuple[str, list[str]]]:
    """Platform coordinates in panels of one unit: position [m], heading (and steering)
    [rad], wheel angles [rad]."""
    robot = ctx.robot
    names = list(robot.platform_coordinates)
    wheels = [j.coordinate for j in robot.tree.joints
              if j.coordinate in names and j.kind.value == "revolute" and abs(j.axis[2]) < 1e-9]
    position = [n for n in names[:2] if coordinate_unit(robot, n) == "m"]
    angles = [n for n in names if n not in position and n not in wheels]
    groups = [("position [m]", position), ("heading, steering [rad]", angles),
              ("wheel angle [rad]", [str(w) for w in wheels])]
    return [(label, members) for label, members in groups if members]


def platform_figure(ctx: ReportContext) -> RenderedFigure:
    """Platform coordinates over time, a panel per unit, with planner bounds.

    As in [JaniakTchon] and [AbdessemedDjebrani] Fig. 8.
    """
    robot, plan = ctx.robot, ctx.plan
    bounds = coordinate_bounds(ctx)
    groups = platform_groups(ctx)
    fig = Figure(figsize=(7.0, 1.7 * len(groups) + 0.6), dpi=DPI, layout=None)
    axes = fig.subplots(len(groups), 1, squeeze=False, sharex=True)[:, 0]
    for ax, (label, names) in zip(axes, groups, strict=True):
        for k, name in enumerate(names):
            color = f"C{k}"
            ax.plot(plan.t, plan.q[:, robot.index(name)], color=color, lw=1.2, label=name)
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
