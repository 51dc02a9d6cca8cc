"""Schema of a scenario's ``limits``: joint ranges, efforts, velocities and accelerations.

Each side is optional (the robot's defaults otherwise); checks that need the robot (lengths,
coordinate names) live in :mod:`mmplan.scenario.loader` and :mod:`mmplan.scenario.rates`.
"""

from __future__ import annotations

import math
from typing import Annotated, Any

from pydantic import AfterValidator, Field, model_validator

from mmplan.scenario.schema_types import Bound, JointBound, Strict, fail, in_range


def _lower(value: float) -> float:
    if value == math.inf:
        raise ValueError("a lower limit of +inf admits no value; use -.inf for none")
    return value


def _upper(value: float) -> float:
    if value == -math.inf:
        raise ValueError("an upper limit of -inf admits no value; use .inf for none")
    return value


#: Sides of a range: finite, or infinite on their own side only (-inf below, +inf above).
JointLower = Annotated[JointBound, AfterValidator(_lower)]
JointUpper = Annotated[JointBound, AfterValidator(_upper)]
Lower = Annotated[Bound, AfterValidator(_lower)]
Upper = Annotated[Bound, AfterValidator(_upper)]


class _Range(Strict):
    """A range given by its sides; where both are given, min <= max entry by entry."""

    min: list[float] | None = None
    max: list[float] | None = None

    @model_validator(mode="after")
    def _ordered(self) -> _Range:
        if self.min is not None and self.max is not None:
            for i, (lo, hi) in enumerate(zip(self.min, self.max, strict=False)):
                if lo > hi:
                    raise fail(f"min[{i}]", f"min {lo:g} > max {hi:g}")
        return self


class JointRangeSpec(_Range):
    """Arm joint limits [rad or m]; a missing side keeps the robot's default; ``-.inf`` /
    ``.inf`` for none (a continuous joint)."""

    min: list[JointLower] | None = None
    max: list[JointUpper] | None = None


class TorqueRangeSpec(_Range):
    """Actuator effort limits [N m or N]; ``.inf`` allowed; the string ``unlimited`` too."""

    min: list[Lower] | None = None
    max: list[Upper] | None = None
    unlimited: bool = False

    @model_validator(mode="before")
    @classmethod
    def _unlimited(cls, data: Any) -> Any:
        if isinstance(data, str):
            if data == "unlimited":
                return {"unlimited": True}
            raise ValueError(f"expected {{min: [...], max: [...]}} or 'unlimited', got {data!r}")
        return data

    @model_validator(mode="after")
    def _exclusive(self) -> TorqueRangeSpec:
        if self.unlimited and (self.min is not None or self.max is not None):
            raise fail("unlimited", "'unlimited' excludes min and max")
        return self


def _positive_limit(value: float) -> float:
    if not value > 0:
        raise ValueError(f"must be > 0, got {value:g}; null turns the limit off")
    return value


#: A rate limit: finite and > 0 (``null`` in YAML, None here, turns it off).
RateBound = Annotated[float, Field(strict=True, allow_inf_nan=False),
                      AfterValidator(in_range), AfterValidator(_positive_limit)]


class RateLimitsSpec(Strict):
    """Velocity [m/s, rad/s] or acceleration [m/s^2, rad/s^2] limits, as absolute bounds.

    A key given overrides the robot's default, ``null`` turns that limit off (which keys were
    given, null included, is ``model_fields_set``; a coordinate given as null maps to None).
    """

    coordinates: dict[str, RateBound | None] | None = None  # by name: arm joints, wheels
    platform_linear: RateBound | None = None  # |(dx, dy)| or |(ddx, ddy)|
    platform_angular: RateBound | None = None  # |dtheta| or |ddtheta|

    @model_validator(mode="before")
    @classmethod
    def _mapping(cls, data: Any) -> Any:
        if not isinstance(data, dict):
            raise ValueError("expected {coordinates: {name: bound}, platform_linear: bound, "
                             f"platform_angular: bound}} or null, got {data!r}")
        return data


class LimitsSpec(Strict):
    """Optional overrides of the robot's limits (``velocity: null``: all velocity limits off)."""

    joints: JointRangeSpec | None = None
    torque: TorqueRangeSpec | None = None
    velocity: RateLimitsSpec | None = None
    acceleration: RateLimitsSpec | None = None
