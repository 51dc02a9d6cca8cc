"""Schema of scenario files (pydantic v2): every key, its type, range and default.

The schema validates what can be checked without the robot: types, finite numbers (of
magnitude at most ``MAX_MAGNITUDE`` = 1e6, torque limits excepted), vector lengths,
positive sizes, min <= max inside one range, unknown keys (``extra="forbid"``).
Checks that need the robot or the planner (lengths of ``start`` and ``limits``, joint limits
at the start, collisions, planner settings) live in :mod:`mmplan.scenario.loader`.

Top-level keys: ``name``, ``robot`` (a built-in robot's name, or a URDF robot
``{urdf: ..., platform: ..., end_effector: ...}``: :mod:`mmplan.scenario.robot_schema`),
``start`` (q0: a list in the robot's coordinate order, ``mmplan robots`` lists them, or a
mapping ``{name: value}`` whose missing coordinates take their defaults,
:mod:`mmplan.scenario.start`), ``goal``, ``obstacles`` (default none), ``limits`` (optional),
``planner`` (``method`` plus that method's settings; unknown keys are errors), ``ground``
(height h [m] of the floor z = h, default 0.0, |h| <= 100; ``null``: no floor; the floor is an
obstacle for every collision sphere whose height depends on the arm,
:mod:`mmplan.robot.ground`).

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
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    TypeAdapter,
    ValidationError,
    model_validator,
)
from pydantic_core import PydanticCustomError

from mmplan.scenario.limits_schema import LimitsSpec
from mmplan.scenario.parse import validation_error
from mmplan.scenario.robot_schema import UrdfRobotSpec
from mmplan.scenario.schema_types import (
    MAX_MAGNITUDE,
    Finite,
    NonNegative,
    Positive,
    Strict,
    Vec3,
    fail,
)
from mmplan.scene.scene import MAX_GROUND_M


# ------------------------------------------------------------------ obstacles
class ObstacleSpec(BaseModel):
    """An obstacle: ``shape`` names a shape registered in :mod:`mmplan.scene`, whose class
    validates its own keys (one-line errors naming the key). The schema knows no shape: adding
    a shape touches only its scene/ file. Numbers are bounded like every scenario number."""

    model_config = ConfigDict(extra="allow", frozen=True)

    shape: str

    @model_validator(mode="after")
    def _valid_for_its_shape(self) -> ObstacleSpec:
        from mmplan.errors import InputError
        from mmplan.scene import obstacle_from_dict

        data = self.model_dump(exclude_none=True)
        for key, value in data.items():
            for k, item in enumerate(value if isinstance(value, list) else [value]):
                if isinstance(item, int | float) and not isinstance(item, bool):
                    where = f"{key}[{k}]" if isinstance(value, list) else key
                    if abs(item) > MAX_MAGNITUDE:
                        raise fail(where, f"|{item:.6g}| is out of range: magnitudes must be "
                                          f"<= {MAX_MAGNITUDE:g}")
        try:
            obstacle_from_dict(data)
        except InputError as exc:
            raise fail(exc.field, exc.problem) from None
        return self


AnyObstacle = ObstacleSpec

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


# ------------------------------------------------------------------ scenario
#: ``ground``: the floor height [m], finite, |h| <= MAX_GROUND_M (``null``: no floor).
Ground = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=-MAX_GROUND_M,
                                le=MAX_GROUND_M)]
#: ``start`` as a mapping: coordinate name -> value [m or rad].
StartMapping = dict[Annotated[str, Field(strict=True, min_length=1)], Finite]
_START_LIST: TypeAdapter[list[float]] = TypeAdapter(list[Finite])
_START_MAPPING: TypeAdapter[dict[str, float]] = TypeAdapter(StartMapping)


def _nested(exc: ValidationError, data: Any, key: str) -> PydanticCustomError:
    """The first error of a nested validation, re-raised with its key path below ``key``."""
    first = validation_error(exc, data, "")
    path = first.field
    return fail(f"{key}{path}" if path.startswith("[") else f"{key}.{path}".rstrip("."),
                first.problem)


class ScenarioSpec(Strict):
    """A whole scenario file. ``planner`` is validated by the chosen method's settings model.

    ``robot`` is a built-in robot's name or a URDF robot (:class:`UrdfRobotSpec`); ``start``
    a list in the robot's coordinate order or a mapping from coordinate names to values.
    """

    name: Annotated[str, Field(strict=True, min_length=1)]
    robot: Annotated[str, Field(strict=True, min_length=1)] | UrdfRobotSpec
    start: list[Finite] | StartMapping
    goal: GoalSpec
    obstacles: list[AnyObstacle] = Field(default_factory=list)
    limits: LimitsSpec | None = None
    planner: dict[str, Any]
    ground: Ground | None = 0.0

    @model_validator(mode="before")
    @classmethod
    def _robot_and_start(cls, data: Any) -> Any:
        """Validate the two keys that take two forms, so that an error names its key path
        (a union would report both forms' errors under their type names)."""
        if not isinstance(data, dict):
            return data
        data = dict(data)
        robot = data.get("robot")
        if isinstance(robot, dict):
            try:
                data["robot"] = UrdfRobotSpec.model_validate(robot)
            except ValidationError as exc:
                raise _nested(exc, robot, "robot") from None
        elif robot is not None and not isinstance(robot, str | UrdfRobotSpec):
            raise fail("robot", "expected a built-in robot's name (mmplan robots) or a URDF "
                                f"robot {{urdf: ..., platform: ..., end_effector: ...}}, got "
                                f"{type(robot).__name__}")
        start = data.get("start")
        if start is not None:
            adapter = _START_MAPPING if isinstance(start, dict) else _START_LIST
            if not isinstance(start, dict | list):
                raise fail("start", "expected a list in the robot's coordinate order or a "
                                    f"mapping {{name: value}}, got {type(start).__name__}")
            try:
                data["start"] = adapter.validate_python(start)
            except ValidationError as exc:
                raise _nested(exc, start, "start") from None
        return data

    @model_validator(mode="after")
    def _method(self) -> ScenarioSpec:
        method = self.planner.get("method")
        if not isinstance(method, str):
            raise fail("planner.method", "required: a method name such as extended-jacobian")
        return self
