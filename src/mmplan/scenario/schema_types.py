"""Value types shared by the scenario schema modules: finite numbers in range, 3-vectors,
limits that may be infinite, the strict model base and key-path errors."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Annotated

from pydantic import AfterValidator, BaseModel, ConfigDict, Field
from pydantic_core import PydanticCustomError

#: Largest magnitude of any scenario number except torque limits (m, rad, s): far beyond any
#: robot workspace, small enough that squares and sums stay exact enough in float64.
MAX_MAGNITUDE = 1e6


def in_range(value: float) -> float:
    """``value`` when its magnitude is at most :data:`MAX_MAGNITUDE`, else a ValueError."""
    if abs(value) > MAX_MAGNITUDE:
        raise ValueError(f"|{value:.6g}| is out of range: magnitudes must be <= {MAX_MAGNITUDE:g}")
    return value


Finite = Annotated[float, Field(strict=True, allow_inf_nan=False), AfterValidator(in_range)]
Positive = Annotated[float, Field(strict=True, allow_inf_nan=False, gt=0),
                     AfterValidator(in_range)]
NonNegative = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=0),
                        AfterValidator(in_range)]


def _not_nan(value: float) -> float:
    if math.isnan(value):
        raise ValueError("expected a number or .inf, got NaN")
    return value


#: A limit: finite or +-inf (``.inf`` in YAML), never NaN.
Bound = Annotated[float, Field(strict=True), AfterValidator(_not_nan)]


def _infinite_orin_range(value: float) -> float:
    return value if math.isinf(value) else in_range(value)


#: A joint limit: +-inf (a continuous joint) or a finite number of magnitude <= MAX_MAGNITUDE.
JointBound = Annotated[float, Field(strict=True), AfterValidator(_not_nan),
                       AfterValidator(_infinite_orin_range)]


def exact_length(n: int, names: str) -> Callable[[list[float]], list[float]]:
    def check(values: list[float]) -> list[float]:
        if len(values) != n:
            raise ValueError(f"expected {n} values {names}, got {len(values)}")
        return values

    return check


Vec3 = Annotated[list[Finite], AfterValidator(exact_length(3, "(x, y, z)"))]
PositiveVec3 = Annotated[list[Positive], AfterValidator(exact_length(3, "(x, y, z)"))]


def fail(key: str, problem: str) -> PydanticCustomError:
    """A validation error about the sub-key ``key`` of the model being validated.

    The key travels in the error's context (``ctx["key"]``) so that the reported key path
    names it (e.g. ``goal.path.times[2]``), not just the model.
    """
    return PydanticCustomError("scenario", problem, {"key": key})


class Strict(BaseModel):
    """Base of every schema model: unknown keys are errors, instances are immutable."""

    model_config = ConfigDict(extra="forbid", frozen=True)
