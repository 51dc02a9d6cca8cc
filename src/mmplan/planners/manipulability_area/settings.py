"""Settings of the manipulability-area planner ([Nagatani]; docs/manipulability_area.md)."""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field, model_validator
from pydantic_core import PydanticCustomError

from mmplan.problem import PlannerSettings

#: Work bounds: the layer stack holds cells x layers manipulabilities (9 bytes each) and one
#: layer's IK temporaries (a few hundred bytes a cell).
MAX_GRID_CELLS = 1_000_000


MAX_STACK_CELLS = 30_000_000


class ManipulabilityAreaSettings(PlannerSettings):
    """Settings of the manipulability-area planner (defaults: docs/manipulability_area.md)."""

    method: Literal["manipulability-area"] = "manipulability-area"
    x_range: tuple[float, float] = Field(default=(0.01, 1.0), description="grid x [m]")
    y_range: tuple[float, float] = Field(default=(-0.8, 1.4), description="grid y [m]")
    resolution: float = Field(default=0.01, gt=0, allow_inf_nan=False, description="cell [m]")
    layers: int = Field(default=31, ge=2, le=1000, description="poses along the task")
    threshold_ratio: float = Field(
        default=0.5, gt=0, le=1, allow_inf_nan=False,
        description="MA threshold / largest w of the whole LMA (ignored when threshold is set)",
    )
    threshold: float | None = Field(
        default=None,
        gt=0,
        allow_inf_nan=False,
        description="absolute MA threshold [m^3]; when set it wins over threshold_ratio",
    )
    heading: float | None = Field(
        default=None,
        allow_inf_nan=False,
        description="base heading [rad]; default faces the surface",
    )
    shoulder: Literal["right", "left"] = "right"
    elbow: Literal["up", "down"] = Field(default="up", description="Corke's ikine_a labels")
    wrist_flip: bool = False
    subgoals: bool = Field(
        default=True, description="plan through sub-goals when no straight segment"
    )
    max_step: float = Field(
        default=0.03,
        gt=0,
        allow_inf_nan=False,
        description="sub-goal search: max base move per layer [m]",
    )
    straight_groups: int = Field(
        default=200, ge=1, description="straight lengths verified exactly, at most"
    )
    respect_joint_limits: bool = Field(
        default=True,
        description="remove cells whose IK solution leaves the joint limits; false plans as "
        "[Nagatani] (limits ignored), and a path that then breaks them is infeasible",
    )
    substeps: int = Field(default=1, ge=1, le=100,
                          description="trajectory rows (and exact checks) per layer interval")
    tool_axis: tuple[float, float, float] = Field(
        default=(0.0, 0.0, 1.0),
        description="numeric IK (robots other than base-6dof): the axis of the end-effector "
        "body's frame that points into the surface",
    )
    ik_seeds: int = Field(default=4, ge=1, le=100,
                          description="numeric IK: random seeds per cell besides the continued one")

    @model_validator(mode="after")
    def _ranges(self) -> ManipulabilityAreaSettings:
        for key, (lo, hi) in (("x_range", self.x_range), ("y_range", self.y_range)):
            if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
                raise ValueError(
                    f"{key}: expected finite [min, max] with min < max, got [{lo}, {hi}]"
                )
        nx, ny = (int(np.floor((hi - lo) / self.resolution + 1e-9)) + 1
                  for lo, hi in (self.x_range, self.y_range))
        if nx * ny > MAX_GRID_CELLS or nx * ny * self.layers > MAX_STACK_CELLS:
            raise PydanticCustomError(
                "scenario",
                f"a grid of {nx} x {ny} cells x {self.layers} layers is too large "
                f"(limits: {MAX_GRID_CELLS:.0e} cells, {MAX_STACK_CELLS:.0e} cells x layers); "
                "use a coarser resolution, smaller ranges or fewer layers",
                {"key": "resolution"},
            )
        if not (np.all(np.isfinite(self.tool_axis)) and np.linalg.norm(self.tool_axis) > 1e-12):
            raise ValueError(f"tool_axis must be a finite non-zero vector, got {self.tool_axis}")
        return self
