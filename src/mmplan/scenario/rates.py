"""Velocity and acceleration limits of a scenario: the robot's defaults with the file's overrides.

``limits.velocity`` and ``limits.acceleration`` (schema :class:`~.limits_schema.RateLimitsSpec`)
override the robot's :class:`~mmplan.robot.RateLimits` key by key; ``null`` turns a limit off
(``velocity: null`` all velocity limits). Coordinate names are checked here, against the robot:
bounds by name are for the coordinates that are not the platform pose (arm joints, wheel
angles, a car's steering angle); the pose (x, y, heading) is bounded through
``platform_linear`` and ``platform_angular``. :func:`rates_dict` writes the effective limits
back in the same form (every coordinate listed, off as null), so that the resolved
scenario.yaml reloads to the same limits whatever the robot's defaults.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from typing import Any

from mmplan.errors import InputError
from mmplan.robot import RateLimits, Robot
from mmplan.scenario.limits_schema import LimitsSpec, RateLimitsSpec

#: Source recorded for a limit that the scenario file sets.
SCENARIO_SOURCE = "scenario file"

# (scenario key, RateLimits field, sources key) of the platform limits, per kind
_PLATFORM = {
    "velocity": (("platform_linear", "platform_speed"), ("platform_angular", "platform_yaw_rate")),
    "acceleration": (("platform_linear", "platform_acceleration"),
                     ("platform_angular", "platform_yaw_acceleration")),
}


def pose_coordinates(robot: Robot) -> tuple[str, ...]:
    """The platform pose coordinates (x, y, heading): the first three of every platform."""
    return robot.platform_coordinates[:3]


def rate_coordinates(robot: Robot) -> tuple[str, ...]:
    """Coordinates that take a bound by name (all but the platform pose), in q order."""
    pose = set(pose_coordinates(robot))
    return tuple(c for c in robot.coordinates if c not in pose)


def resolve_rates(spec: LimitsSpec | None, robot: Robot) -> RateLimits:
    """The robot's rate limits with the scenario's overrides applied.

    Raises:
        InputError: an unknown coordinate name, or a platform pose coordinate given by name.
    """
    rates = robot.limits.rates
    if spec is None:
        return rates
    for kind in ("velocity", "acceleration"):
        if kind in spec.model_fields_set:
            rates = _override(rates, kind, getattr(spec, kind), robot)
    return rates


def _override(rates: RateLimits, kind: str, spec: RateLimitsSpec | None,
              robot: Robot) -> RateLimits:
    bounds = dict(getattr(rates, kind))
    sources = dict(rates.sources)
    platform: dict[str, float] = {}
    if spec is None:  # `velocity: null`: every limit of this kind off
        bounds.clear()
        platform = {field: math.inf for _, field in _PLATFORM[kind]}
    else:
        given = spec.model_fields_set
        if "coordinates" in given:
            for name, value in _checked(spec.coordinates or {}, kind, robot).items():
                bounds.pop(name, None)
                sources.pop(f"{kind}.{name}", None)
                if value is not None:
                    bounds[name] = float(value)
                    sources[f"{kind}.{name}"] = SCENARIO_SOURCE
        for key, field in _PLATFORM[kind]:
            if key in given:
                value = getattr(spec, key)
                platform[field] = math.inf if value is None else float(value)
    for field, value in platform.items():
        sources.pop(field, None)
        if math.isfinite(value):
            sources[field] = SCENARIO_SOURCE
    if spec is None:
        sources = {k: v for k, v in sources.items() if not k.startswith(f"{kind}.")}
    changes: dict[str, Any] = {kind: bounds, **platform, "sources": sources}
    return replace(rates, **changes)


def _checked(values: Mapping[str, float | None], kind: str,
             robot: Robot) -> Mapping[str, float | None]:
    valid = rate_coordinates(robot)
    pose = pose_coordinates(robot)
    for name in values:
        key = f"limits.{kind}.coordinates.{name}"
        if name in pose:
            raise InputError(key, f"{name} is a platform pose coordinate; bound the platform "
                             f"with {kind}.platform_linear (x, y) or platform_angular "
                             f"({pose[2]})")
        if name not in valid:
            raise InputError(key, f"unknown coordinate {name!r} of {robot.name}; valid: "
                             f"{', '.join(valid)}")
    return values


def rates_dict(rates: RateLimits, robot: Robot) -> dict[str, Any]:
    """``{velocity: ..., acceleration: ...}`` as in a scenario file (off as null, all off: null)."""
    out: dict[str, Any] = {}
    for kind in ("velocity", "acceleration"):
        bounds: Mapping[str, float] = getattr(rates, kind)
        coords = {c: _value(bounds.get(c, math.inf)) for c in rate_coordinates(robot)}
        entry: dict[str, Any] = {"coordinates": coords}
        for key, field in _PLATFORM[kind]:
            entry[key] = _value(getattr(rates, field))
        values = [*coords.values(), *(entry[key] for key, _ in _PLATFORM[kind])]
        out[kind] = entry if any(v is not None for v in values) else None
    return out


def _value(bound: float) -> float | None:
    return float(bound) if math.isfinite(bound) else None
