"""Schema of scenario files (pydantic v2): every key, its type, range and default.

The schema validates what can be checked without the robot: types, finite numbers (of
magnitude at most ``MAX_MAGNITUDE`` = 1e6, torque limits excepted), vector lengths,
positive sizes, min <= max inside one range, unknown keys (``extra="forbid"``).
Checks that need the robot or the planner (lengths of ``start`` and ``limits``, joint limits
at the start, collisions, planner settings) live in :mod:`mmplan.scenario.loader`.

Top-level keys: ``name``, ``robot`` (a built-in robot), ``start`` (q0 in the robot's
coordinate order, ``mmplan robots`` lists them), ``goal``, ``obstacles`` (default none),
``limits`` (optional), ``planner`` (``method`` plus that method's settings; unknown keys are
errors).

Goal forms (exactly one of ``position``, ``path``, ``segment``; plus ``tolerance`` [m],
default 0.001):

* ``position: [x, y, z]`` -- :class:`~mmplan.task.ReachPoint`;
* ``path: {kind: line, start: [3], velocity: [3], duration: s}`` -- :class:`~mmplan.task.LinePath`;
* ``path: {kind: waypoints, points: [[3], ...], times: [s, ...]}`` --
  :class:`~mmplan.task.WaypointPath` (quintic rest-to-rest blend between waypoints);
* ``path: {kind: polynomial, coefficients: [[c0], [c1], ...], duration: s}`` --
  :class:`~mmplan.task.PolynomialPath` (X_d(t) = sum_k c_k t^k);
* ``segment: {start: [3], end: [3], normal: [3]}`` -- :class:`~mmplan.task.DrawSegment`.

Obstacles (``shape`` selects the keys; every shape also takes ``influence: m``, the planner
neighbourhood; lengths in m, angles in rad):

* ``{shape: superellipsoid, center: [3], semi_axes: [3], exponents: [e1, e2], yaw: 0}``;
* ``{shape: sphere, center: [3], radius: r}``;
* ``{shape: cylinder, base_center: [3], radius: r, height: h}`` (vertical);
* ``{shape: box, center: [3], size: [3], yaw: 0}``.

Limits (each side optional; the robot's defaults otherwise):
``joints: {min: [...], max: [...]}`` over the arm coordinates;
``torque: {min: [...], max: [...]}`` over the actuators (``.inf`` allowed) or
``torque: unlimited``;
``velocity`` and ``acceleration``: ``{coordinates: {name: bound}, platform_linear: bound,
platform_angular: bound}``, absolute bounds (> 0) on |dq|, |ddq| of named coordinates and on the
platform's planar speed / acceleration and yaw rate / acceleration; a key given overrides the
robot's default, ``null`` turns that limit off (``velocity: null`` all of them). Coordinate
names are checked against the robot in :mod:`mmplan.scenario.rates`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Annotated, Any, Literal

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, model_validator
from pydantic_core import PydanticCustomError

#: Largest magnitude of any scenario number except torque limits (m, rad, s): far beyond any
#: robot workspace, small enough that squares and sums stay exact enough in float64.
MAX_MAGNITUDE = 1e6


def _in_range(value: float) -> float:
    if abs(value) > MAX_MAGNITUDE:
        raise ValueError(f"|{value:.6g}| is out of range: magnitudes must be <= {MAX_MAGNITUDE:g}")
    return value


Finite = Annotated[float, Field(strict=True, allow_inf_nan=False), AfterValidator(_in_range)]
Positive = Annotated[float, Field(strict=True, allow_inf_nan=False, gt=0),
                     AfterValidator(_in_range)]
NonNegative = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=0),
                        AfterValidator(_in_range)]


def _not_nan(value: float) -> float:
    if math.isnan(value):
        raise ValueError("expected a number or .inf, got NaN")
    return value


#: A limit: finite or +-inf (``.inf`` in YAML), never NaN.
Bound = Annotated[float, Field(strict=True), AfterValidator(_not_nan)]


def _length(n: int, names: str) -> Callable[[list[float]], list[float]]:
    def check(values: list[float]) -> list[float]:
        if len(values) != n:
            raise ValueError(f"expected {n} values {names}, got {len(values)}")
        return values

    return check


Vec3 = Annotated[list[Finite], AfterValidator(_length(3, "(x, y, z)"))]
PositiveVec3 = Annotated[list[Positive], AfterValidator(_length(3, "(x, y, z)"))]


def fail(key: str, problem: str) -> PydanticCustomError:
    """A validation error about the sub-key ``key`` of the model being validated.

    The key travels in the error's context (``ctx["key"]``) so that the reported key path
    names it (e.g. ``goal.path.times[2]``), not just the model.
    """
    return PydanticCustomError("scenario", problem, {"key": key})


class Strict(BaseModel):
    """Base of every schema model: unknown keys are errors, instances are immutable."""

    model_config = ConfigDict(extra="forbid", frozen=True)


# ------------------------------------------------------------------ obstacles
class ObstacleSpec(Strict):
    """Keys shared by every obstacle."""

    influence: Positive | None = Field(
        None, description="planner neighbourhood [m] around the (enlarged) surface")


class SuperellipsoidSpec(ObstacleSpec):
    """Barr superellipsoid (docs/conventions.md): centre, semi-axes [m], exponents (e1, e2), yaw."""

    shape: Literal["superellipsoid"]
    center: Vec3
    semi_axes: PositiveVec3
    exponents: Annotated[list[Positive], AfterValidator(_length(2, "(e1, e2)"))]
    yaw: Finite = 0.0


class SphereSpec(ObstacleSpec):
    """Sphere: centre [m], radius [m]."""

    shape: Literal["sphere"]
    center: Vec3
    radius: Positive


class CylinderSpec(ObstacleSpec):
    """Vertical cylinder standing on ``base_center`` [m], radius and height [m]."""

    shape: Literal["cylinder"]
    base_center: Vec3
    radius: Positive
    height: Positive


class BoxSpec(ObstacleSpec):
    """Box: centre [m], edge lengths ``size`` [m], rotation ``yaw`` [rad] about z."""

    shape: Literal["box"]
    center: Vec3
    size: PositiveVec3
    yaw: Finite = 0.0


AnyObstacle = Annotated[SuperellipsoidSpec | SphereSpec | CylinderSpec | BoxSpec,
                        Field(discriminator="shape")]

# ------------------------------------------------------------------ goal
class LineSpec(Strict):
    """Straight line X_d(t) = start + t velocity on [0, duration]."""

    kind: Literal["line"]
    start: Vec3
    velocity: Vec3
    duration: Positive


class WaypointsSpec(Strict):
    """Waypoints reached at strictly increasing times (quintic blend between them)."""

    kind: Literal["waypoints"]
    points: Annotated[list[Vec3], Field(min_length=2)]
    times: list[NonNegative]

    @model_validator(mode="after")
    def _times(self) -> WaypointsSpec:
        if len(self.times) != len(self.points):
            raise fail("times", f"expected {len(self.points)} values (one per point), "
                                f"got {len(self.times)}")
        for i in range(1, len(self.times)):
            if self.times[i] <= self.times[i - 1]:
                raise fail(f"times[{i}]", f"{self.times[i]:g} <= times[{i - 1}] = "
                                          f"{self.times[i - 1]:g}; times must increase strictly")
        return self


class PolynomialSpec(Strict):
    """X_d(t) = sum_k coefficients[k] t^k on [0, duration]."""

    kind: Literal["polynomial"]
    coefficients: Annotated[list[Vec3], Field(min_length=1)]
    duration: Positive


AnyPath = Annotated[LineSpec | WaypointsSpec | PolynomialSpec, Field(discriminator="kind")]


class SegmentSpec(Strict):
    """Draw the segment start -> end on a surface with outward ``normal``."""

    start: Vec3
    end: Vec3
    normal: Vec3

    @model_validator(mode="after")
    def _geometry(self) -> SegmentSpec:
        if self.start == self.end:
            raise fail("end", "equals start; a segment needs two distinct points")
        if not any(self.normal):
            raise fail("normal", "must be a non-zero vector")
        d = [b - a for a, b in zip(self.start, self.end, strict=True)]
        n = self.normal
        cross = (d[1] * n[2] - d[2] * n[1], d[2] * n[0] - d[0] * n[2], d[0] * n[1] - d[1] * n[0])
        if math.hypot(*cross) <= 1e-6 * math.hypot(*d) * math.hypot(*n):
            raise fail("normal", "is parallel to the segment end - start; the surface normal "
                                 "must be transverse to the segment")
        return self


class GoalSpec(Strict):
    """Exactly one of ``position``, ``path``, ``segment``, plus ``tolerance`` [m]."""

    position: Vec3 | None = None
    path: AnyPath | None = None
    segment: SegmentSpec | None = None
    tolerance: Positive = 1e-3

    @model_validator(mode="after")
    def _exactly_one(self) -> GoalSpec:
        given = [k for k in ("position", "path", "segment") if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError("expected exactly one of position, path, segment; got "
                             + (", ".join(given) if given else "none"))
        return self


# ------------------------------------------------------------------ limits
class JointRangeSpec(Strict):
    """Arm joint limits [rad or m]; a missing side keeps the robot's default."""

    min: list[Finite] | None = None
    max: list[Finite] | None = None


class TorqueRangeSpec(Strict):
    """Actuator effort limits [N m or N]; ``.inf`` allowed; the string ``unlimited`` too."""

    min: list[Bound] | None = None
    max: list[Bound] | None = None
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
                      AfterValidator(_in_range), AfterValidator(_positive_limit)]


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


# ------------------------------------------------------------------ scenario
class ScenarioSpec(Strict):
    """A whole scenario file. ``planner`` is validated by the chosen method's settings model."""

    name: Annotated[str, Field(strict=True, min_length=1)]
    robot: Annotated[str, Field(strict=True)]
    start: list[Finite]
    goal: GoalSpec
    obstacles: list[AnyObstacle] = Field(default_factory=list)
    limits: LimitsSpec | None = None
    planner: dict[str, Any]

    @model_validator(mode="after")
    def _method(self) -> ScenarioSpec:
        method = self.planner.get("method")
        if not isinstance(method, str):
            raise fail("planner.method", "required: a method name such as extended-jacobian")
        return self
