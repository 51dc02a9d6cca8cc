"""Settings of the endogenous configuration space planner ([JaniakTchon]; docs/endogenous.md)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from mmplan.problem import PlannerSettings, SettingsModel

#: Input ranges (work bounds: a run costs about max_iterations x steps rollouts of
#: sum(basis_terms) parameters; beyond these the run would hang or overflow).
MAX_HORIZON_S = 1e3


MAX_BASIS_TERMS = 51


MAX_LAMBDA = 1e4


MAX_TOLERANCE_M = 1.0


MAX_ITERATIONS = 100_000


MAX_STEPS = 20_000


class BoundSetting(SettingsModel):
    """A state bound ``min <= q[coordinate] <= max`` (platform or arm coordinate)."""

    coordinate: str
    min: float = Field(strict=True, allow_inf_nan=False)
    max: float = Field(strict=True, allow_inf_nan=False)


class EndogenousSettings(PlannerSettings):
    """Settings of the endogenous configuration space planner (defaults: docs/endogenous.md)."""

    method: Literal["endogenous"] = "endogenous"
    t_max: float = Field(
        120.0, gt=0, allow_inf_nan=False,
        description="longest plan [s] after re-timing for the robot's rate limits (a plan "
        "that needs a longer horizon is infeasible); max_iterations is the iteration budget",
    )
    horizon: float = Field(1.0, gt=0, le=MAX_HORIZON_S, allow_inf_nan=False,
                           description="control horizon T [s]")
    basis_terms: tuple[Annotated[int, Field(ge=1, le=MAX_BASIS_TERMS)], ...] = Field(
        (3, 5), description="Fourier terms s_i + 1 per platform control (1, sin, cos, ...)"
    )
    lambda0: tuple[Annotated[float, Field(allow_inf_nan=False, ge=-MAX_LAMBDA,
                                          le=MAX_LAMBDA)], ...] | None = Field(
        None, description="initial Fourier coefficients, control by control; default zeros"
    )
    gamma: float = Field(0.1, gt=0, le=1, allow_inf_nan=False,
                         description="decay rate of the theta-iteration")
    tolerance: float | None = Field(
        None, gt=0, le=MAX_TOLERANCE_M, allow_inf_nan=False,
        description="stop when |e_task| < tolerance [m]; default the goal tolerance",
    )
    bound_tolerance: float | None = Field(
        None, gt=0, le=MAX_TOLERANCE_M, allow_inf_nan=False,
        description="stop also needs |bound outputs| < this; default = tolerance",
    )
    max_iterations: int = Field(3000, ge=1, le=MAX_ITERATIONS,
                                description="iteration budget (the planner's only budget)")
    steps: int = Field(200, ge=4, le=MAX_STEPS, description="RK4 steps on [0, T]")
    bounds: tuple[BoundSetting, ...] = ()
    sharpness: float = Field(50.0, gt=0, le=1e6, allow_inf_nan=False,
                             description="a of the plus function p(x, a)")
    regularizer_weight: float = Field(1.0, gt=0, le=1e6, allow_inf_nan=False,
                                      description="w of r(q) = w (q - c)^2")
    singular_threshold: float = Field(1e-8, gt=0, lt=1, allow_inf_nan=False,
                                      description="min singular value of J")
    codegen: bool = Field(True, description="compile the rollout to C (cached); else CasADi VM")
