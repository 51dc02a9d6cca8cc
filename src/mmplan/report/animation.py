"""Data of the 3D animation: robot points per frame, paths and obstacle wireframes.

The viewer (``viewer.js``, inlined in the page) draws links as segments between body origins
(from :meth:`Robot.body_positions`), the collision points, the end effector, its path and the
platform path, and obstacle wireframes sampled from their superellipsoid models. Frames are
the trajectory decimated to at most ``max_frames`` samples, stored as little-endian int16
millimetres (float32 metres when a coordinate exceeds 32 m) in base64.
"""

from __future__ import annotations

import base64
import json
from importlib import resources
from typing import Any

import numpy as np

from mmplan.report.context import ReportContext, decimation
from mmplan.report.shapes import wireframe

MAX_FRAMES = 2000
COLORS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2")


def _flat(points: np.ndarray, decimals: int = 4) -> list[float]:
    return [round(float(v), decimals) for v in np.asarray(points, dtype=float).ravel()]


def frame_points(ctx: ReportContext, q: np.ndarray, bodies: list[str]) -> np.ndarray:
    """Points of one frame: body origins, end effector, collision points, (B + 1 + P, 3)."""
    robot = ctx.robot
    positions = robot.body_positions(q)
    rows = [positions[b] for b in bodies] + [robot.ee_position(q)]
    if robot.collision:
        return np.vstack([np.array(rows), robot.collision_points(q)])
    return np.array(rows)


def scene_data(ctx: ReportContext, max_frames: int = 1000) -> dict[str, Any]:
    """The viewer's JSON document (see module docstring)."""
    if not 2 <= max_frames <= MAX_FRAMES:
        raise ValueError(f"max_frames must be in [2, {MAX_FRAMES}], got {max_frames}")
    robot, plan = ctx.robot, ctx.plan
    index = decimation(plan.samples, max_frames)
    bodies = list(robot.body_positions(plan.q[0]))
    position = {b: i for i, b in enumerate(bodies)}
    links = [
        [position[j.parent], position[j.child]]
        for j in robot.tree.joints
        if j.parent in position and j.child in position
    ]
    ee_index = len(bodies)
    if robot.end_effector.body in position:
        links.append([position[robot.end_effector.body], ee_index])
    frames = np.array([frame_points(ctx, plan.q[i], bodies) for i in index])  # (K, P, 3)
    if np.max(np.abs(frames)) < 32.0:
        payload, dtype, scale = np.round(frames * 1000.0).astype("<i2"), "int16", 1e-3
    else:
        payload, dtype, scale = frames.astype("<f4"), "float32", 1.0
    base_col = position.get("platform")
    base = (
        frames[:, base_col, :]
        if base_col is not None
        else np.column_stack([plan.q[index, :2], np.zeros(len(index))])
    )
    obstacles = []
    for j, view in enumerate(ctx.obstacles):
        lines = wireframe(view.obstacle.superellipsoid())
        obstacles.append(
            {
                "label": view.label,
                "color": COLORS[j % len(COLORS)],
                "lines": [_flat(line) for line in lines],
            }
        )
    goal = (plan.scenario.get("goal") or {}).get("position")
    return {
        "t": [round(float(v), 6) for v in plan.t[index]],
        "nBodies": len(bodies),
        "nPoints": int(frames.shape[1]),
        "eeIndex": ee_index,
        "bodies": bodies,
        "links": links,
        "dtype": dtype,
        "scale": scale,
        "frames": base64.b64encode(payload.tobytes()).decode("ascii"),
        "eePath": _flat(plan.ee[index]),
        "basePath": _flat(base),
        "obstacles": obstacles,
        "goal": [float(v) for v in goal] if goal is not None else None,
    }


def viewer_script() -> str:
    """Source of the inline viewer (package data ``viewer.js``)."""
    return (resources.files("mmplan.report") / "viewer.js").read_text(encoding="utf-8")


def scene_json(data: dict[str, Any]) -> str:
    """JSON safe to embed in a ``<script type="application/json">`` element."""
    return json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
