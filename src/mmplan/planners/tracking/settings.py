"""Settings of the path trackers ([AbdessemedDjebrani]; docs/tracking.md).

:class:`TrackingSettings` (step and stop rules) is shared by :class:`PseudoinverseSettings`
and :class:`ImpedanceSettings`.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field, model_validator

from mmplan.problem import PlannerSettings


class TrackingSettings(PlannerSettings):
    """Settings shared by the path trackers of [AbdessemedDjebrani] (step and stop rules)."""

    dt: float = Field(default=0.01, gt=0, allow_inf_nan=False, description="integration step [s]")

    min_singular_value: float = Field(
        default=0.02,
        gt=0,
        allow_inf_nan=False,
        description="stop (stalled) below this smallest singular value of the task matrix",
    )
    max_error: float = Field(
        default=0.1,
        gt=0,
        allow_inf_nan=False,
        description="stop (diverged) when the error exceeds the initial one by this [m]",
    )
    settle_time: float = Field(
        default=2.0,
        ge=0,
        allow_inf_nan=False,
        description="report the max tracking error after this time [s]",
    )
    stop_on_collision: bool = Field(
        default=True, description="stop (stalled) when a collision sphere touches an obstacle"
    )
    codegen: bool | None = Field(
        default=None,
        description="compile the control step to C (null: when a compiler is present; cached "
        "per robot model, settings and obstacle kinds); false: CasADi's virtual machine",
    )


class PseudoinverseSettings(TrackingSettings):
    """Settings of the weighted-pseudoinverse tracker; defaults are the paper's s.2 example
    (docs/tracking.md)."""

    method: Literal["pseudoinverse"] = "pseudoinverse"
    gain: float = Field(
        2.0, ge=0, allow_inf_nan=False, description="drift correction K = gain I [1/s]"
    )
    beta1: float = Field(0.5, ge=0, allow_inf_nan=False, description="joint-limit potential weight")
    beta2: float = Field(1.0, ge=0, allow_inf_nan=False, description="obstacle potential weight")
    k1: float = Field(0.002, ge=0, allow_inf_nan=False, description="obstacle potential gain [m^2]")
    d0: float = Field(
        0.6,
        gt=0,
        allow_inf_nan=False,
        description="influence distance d0 [m] (an obstacle's own influence wins)",
    )
    d_floor: float = Field(
        0.02,
        gt=0,
        allow_inf_nan=False,
        description="below this distance [m] V2 continues linearly (finite)",
    )
    platform_range: tuple[float, ...] | None = Field(
        None, description="ranges b_i of the platform coordinates; default x, y 10 m, angles 2 pi"
    )

    @model_validator(mode="after")
    def _check(self) -> PseudoinverseSettings:
        if self.d_floor >= self.d0:
            raise ValueError(f"d_floor ({self.d_floor}) must be below d0 ({self.d0})")
        if self.platform_range is not None and not all(
            b > 0 and np.isfinite(b) for b in self.platform_range
        ):
            raise ValueError(
                f"platform_range must hold positive finite ranges, got {self.platform_range}"
            )
        return self


class ImpedanceSettings(TrackingSettings):
    """Settings of the virtual-impedance tracker; defaults are the paper's s.3 example
    (docs/tracking.md)."""

    method: Literal["impedance"] = "impedance"
    dt: float = Field(default=0.001, gt=0, allow_inf_nan=False, description="integration step [s]")
    gain: float = Field(5.0, ge=0, allow_inf_nan=False, description="W_t = gain I [1/s]")
    platform_heading: float = Field(
        np.pi / 4, allow_inf_nan=False, description="theta of the platform pose task [rad]"
    )
    platform_offset: tuple[float, float] = Field(
        (0.0, 0.0), description="platform task x, y = end-effector path x, y + this offset [m]"
    )
    d_max: float = Field(
        1.0,
        gt=0,
        allow_inf_nan=False,
        description="repulsion zone [m] (an obstacle's own influence wins)",
    )
    d_min: float = Field(0.15, ge=0, allow_inf_nan=False, description="saturation distance [m]")
    b_obs: float = Field(
        0.25,
        ge=0,
        allow_inf_nan=False,
        description="force coefficient [N/m^2]; 0 switches the impedance off",
    )
    damping: float = Field(1.0, gt=0, allow_inf_nan=False, description="B_d of Z_d = B_d s + K_d")
    stiffness: float = Field(1.0, ge=0, allow_inf_nan=False, description="K_d of Z_d")
    settle_time: float = Field(
        1.0,
        ge=0,
        allow_inf_nan=False,
        description="report the max tracking error after this time [s]",
    )

    @model_validator(mode="after")
    def _check(self) -> ImpedanceSettings:
        if self.d_min >= self.d_max:
            raise ValueError(f"d_min ({self.d_min}) must be below d_max ({self.d_max})")
        if not all(np.isfinite(v) for v in self.platform_offset):
            raise ValueError(f"platform_offset must be finite, got {self.platform_offset}")
        return self
