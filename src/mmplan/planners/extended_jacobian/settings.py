"""Settings of the extended-Jacobian planner ([PajakPajak], [Pajak]; docs/extended_jacobian.md).

The scenario file's ``planner:`` block is validated against :class:`ExtendedJacobianSettings`
(unknown keys and non-finite numbers are errors naming the key).
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator
from pydantic_core import PydanticCustomError

from mmplan.problem import PlannerSettings, SettingsModel


class VirtualControlSettings(SettingsModel):
    """Virtual control ([PajakPajak] s.4, [Pajak] s.4)."""

    enabled: bool | None = Field(
        None, description="None: on when the robot has finite torque limits"
    )
    eps_tau: float = Field(0.1, ge=0, lt=1, allow_inf_nan=False,
                           description="safety zone size, [PajakPajak] eq. (25)")
    growth: Literal["constant", "distance"] = Field(
        "constant",
        description="constant: du/dt = rho (1 - u) ([PajakPajak]); "
        "distance: (1 - u)/rho(t) ([Pajak])",
    )
    rho: float = Field(1.0, gt=0, allow_inf_nan=False, description="rate of the constant law [1/s]")
    rho_min: float = Field(0.01, gt=0, allow_inf_nan=False,
                           description="rho(t) at the goal (distance law) [s]")
    rho_max: float = Field(10.0, gt=0, allow_inf_nan=False,
                           description="rho(t) far from the goal (distance law) [s], >= rho_min")
    mode: Literal["auto", "feedback", "time"] = Field(
        "auto",
        description="feedback: eq. (23) scales v2 ([PajakPajak], [Pajak]); time: true time "
        "scaling of the whole generator; auto: time when the scene has obstacles, else feedback",
    )
    budget_perturbation: bool = Field(
        True, description="scale the obstacle push to fit the torque budget (else s = 1, unscaled)"
    )

    @model_validator(mode="after")
    def _rho_range(self) -> VirtualControlSettings:
        if self.rho_min > self.rho_max:
            raise PydanticCustomError(
                "scenario", f"rho_min {self.rho_min:g} > rho_max {self.rho_max:g}",
                {"key": "rho_min"})
        return self


class ExtendedJacobianSettings(PlannerSettings):
    """Settings of the extended-Jacobian planner (defaults: docs/extended_jacobian.md).

    Every number is finite; ``t_max / dt`` is bounded (see :class:`PlannerSettings`).
    """

    method: Literal["extended-jacobian"] = "extended-jacobian"
    t_max: float = Field(60.0, gt=0, allow_inf_nan=False, description="simulated seconds")
    dt: float = Field(0.01, gt=0, le=0.05, allow_inf_nan=False,
                      description="integration step [s] (RK4; 10 ms: path within 0.05 mm of 2 ms)")
    lambda_p: float = Field(1.75, gt=0, allow_inf_nan=False,
                            description="Lambda_P, [PajakPajak] eq. (14)")
    lambda_v: float = Field(2.78, gt=0, allow_inf_nan=False,
                            description="Lambda_V (>= 2 sqrt(Lambda_P): no overshoot)")
    lambda_ii: float = Field(1.0, gt=0, allow_inf_nan=False,
                             description="Lambda_II, Pfaffian error rate")
    penalty_weight: float = Field(0.01, gt=0, allow_inf_nan=False,
                                  description="joint-limit penalty w")
    posture_weight: float | None = Field(
        None, ge=0, allow_inf_nan=False,
        description="posture term beta [1/rad^2] on every arm joint (posture.posture_term); "
        "null: 1 on wrist joints, and on every arm joint when more than 4 position the "
        "manipulability point, else 0 (the papers' youBots)",
    )
    obstacle_margin: float = Field(0.05, ge=0, allow_inf_nan=False,
                                   description="enlargement of obstacles [m]")
    influence: float = Field(
        0.15, gt=0, allow_inf_nan=False,
        description="neighbourhood delta when an obstacle has none [m]",
    )
    varrho: float = Field(1.0, gt=0, allow_inf_nan=False,
                          description="perturbation gain, eq. (19)")
    arm_gradient_weight: float = Field(
        0.3, ge=0, allow_inf_nan=False, description="obstacle-gradient weight on arm joints"
    )
    virtual_control: VirtualControlSettings = Field(
        default_factory=lambda: VirtualControlSettings.model_validate({})
    )
    stall_window: float = Field(1.5, gt=0, allow_inf_nan=False,
                                description="no-progress window for stall detection [s] "
                                "(1.5: 3 s cost the random sets 3 goals, see their test)")
    stall_progress: float = Field(
        1e-3, ge=0, allow_inf_nan=False, description="error decrease expected over the window [m]"
    )
    escape: bool = Field(True, description="tangential push when stalled near an obstacle")
    escape_gain: float = Field(
        4.0, gt=0, allow_inf_nan=False, description="escape push per (1 + Lambda_P |e|) [m/s^2]"
    )
    escape_time: float = Field(2.0, gt=0, allow_inf_nan=False,
                               description="duration of one escape push [s]")
    max_escapes: int = Field(5, ge=0, le=1000)
    cond_limit: float = Field(1e8, gt=1, allow_inf_nan=False,
                              description="cond(E) above which the run diverged")
    codegen: bool | None = Field(
        None,
        description="compile the generator to C (once per robot model and obstacle shape "
        "types, cached on disk; scenes, goals and partitions are parameters); null: when a "
        "compiler is present and the model builds in seconds (the youBots; a larger one "
        "runs on the virtual machine unless compiled before); false: the virtual machine",
    )
    vibration: bool = Field(
        True, description="the CLI and mmplan.analysis.analyse add the tip-vibration study "
        "([Pajak] s.4, experiment of s.5.3, Figs. 8-9) after planning (not part of planning "
        "or compute_time_s)",
    )
