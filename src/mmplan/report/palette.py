"""Colours shared by the figures and the 3D view, so that a reader matches them at a glance."""

from __future__ import annotations

#: Obstacle colours, in scenario order. No orange, grey, red or green: those are the arm,
#: the platform's path, the end effector's path (and the limits) and the goal.
OBSTACLE_COLORS = ("#1f77b4", "#9467bd", "#8c564b", "#17becf", "#bcbd22", "#e377c2", "#393b79")
EE_COLOR = "#d62728"
PLATFORM_PATH_COLOR = "#7f7f7f"
GOAL_COLOR = "#2ca02c"


def obstacle_color(j: int) -> str:
    """Colour of obstacle j (0-based)."""
    return OBSTACLE_COLORS[j % len(OBSTACLE_COLORS)]
