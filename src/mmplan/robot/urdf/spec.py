"""What a URDF robot needs besides the file: platform kind and wheels, mount, locked joints.

The same keys as a scenario's ``robot: {urdf: ...}`` entry, validated here with one-line
:class:`~mmplan.errors.InputError` messages that name the key:

.. code-block:: yaml

    platform: {kind: differential-drive, wheels: [wheel_left_joint, wheel_right_joint]}
    end_effector: arm_tool_link
    locked: {head_1_joint: 0.3}
    mount: {xyz: [0.15, 0, 0.3], rpy: [0, 0, 0]}      # only for an arm-only URDF
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from enum import Enum
from typing import Any

from mmplan.errors import InputError

Vec3 = tuple[float, float, float]


class PlatformKind(Enum):
    """Platform kinds a URDF robot can have (see :mod:`mmplan.robot.bases`)."""

    DIFFERENTIAL_DRIVE = "differential-drive"
    UNICYCLE = "unicycle"
    OMNIDIRECTIONAL = "omnidirectional"


def _vec(value: Any, key: str, size: int = 3) -> tuple[float, ...]:
    try:
        out = tuple(float(v) for v in value)
    except (TypeError, ValueError):
        raise InputError(key, f"expected {size} numbers, got {value!r}") from None
    if len(out) != size or not all(math.isfinite(v) for v in out):
        raise InputError(key, f"expected {size} finite numbers, got {value!r}")
    return out


def _positive(value: Any, key: str) -> float:
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise InputError(key, f"expected a number, got {value!r}") from None
    if not math.isfinite(out) or out <= 0:
        raise InputError(key, f"expected a positive number, got {value!r}")
    return out


def _check_keys(data: Mapping[str, Any], allowed: Sequence[str], key: str) -> None:
    if not isinstance(data, Mapping):
        raise InputError(key, f"expected a mapping, got {data!r}")
    unknown = sorted(set(data) - set(allowed))
    if unknown:
        raise InputError(f"{key}.{unknown[0]}", f"unknown key; allowed: {', '.join(allowed)}")


@dataclass(frozen=True)
class PlatformBox:
    """A platform body given as a uniform box (for an arm-only URDF).

    Attributes:
        size: Edge lengths (x, y, z) [m].
        mass: Mass [kg].
        center: Box centre in the platform frame [m]; default: on the ground, (0, 0, z/2).
    """

    size: Vec3
    mass: float
    center: Vec3 | None = None

    @property
    def box_center(self) -> Vec3:
        """Centre of the box in the platform frame [m]."""
        return self.center if self.center is not None else (0.0, 0.0, self.size[2] / 2)

    @staticmethod
    def parse(data: Mapping[str, Any], key: str) -> PlatformBox:
        """Validate ``{size, mass, center}``."""
        _check_keys(data, ("size", "mass", "center"), key)
        for required in ("size", "mass"):
            if required not in data:
                raise InputError(f"{key}.{required}", "missing")
        size = _vec(data["size"], f"{key}.size")
        for i, s in enumerate(size):
            if s <= 0:
                raise InputError(f"{key}.size[{i}]", f"expected a positive edge length, got {s}")
        center = data.get("center")
        return PlatformBox(
            (size[0], size[1], size[2]),
            _positive(data["mass"], f"{key}.mass"),
            None if center is None else _vec3(_vec(center, f"{key}.center")),
        )


def _vec3(v: tuple[float, ...]) -> Vec3:
    return (v[0], v[1], v[2])


@dataclass(frozen=True)
class PlatformSpec:
    """Platform of a URDF robot.

    Attributes:
        kind: Platform kind.
        wheels: Differential drive: the two wheel coordinates, left (+y) first. For a whole
            robot these are the URDF's continuous wheel joints; for an arm-only URDF (with a
            ``mount``) they are new coordinate names.
        wheel_radius: Wheel radius r [m]; default: the wheel link's collision cylinder.
        half_track: Half the distance between the wheels d [m]; default: from the wheel
            joints' origins.
        box: Platform body for an arm-only URDF (mass and collision shape).
        wheel_mass: Mass of each wheel of an arm-only URDF's differential drive (thin disc) [kg].
    """

    kind: PlatformKind
    wheels: tuple[str, ...] = ()
    wheel_radius: float | None = None
    half_track: float | None = None
    box: PlatformBox | None = None
    wheel_mass: float = 1.0

    @staticmethod
    def parse(data: Mapping[str, Any] | PlatformSpec, key: str = "robot.platform") -> PlatformSpec:
        """Validate a ``platform:`` mapping (or pass a PlatformSpec through)."""
        if isinstance(data, PlatformSpec):
            return data
        allowed = ("kind", "wheels", "wheel_radius", "half_track", "box", "wheel_mass")
        _check_keys(data, allowed, key)
        if "kind" not in data:
            raise InputError(f"{key}.kind", "missing; one of "
                             f"{', '.join(k.value for k in PlatformKind)}")
        try:
            kind = PlatformKind(data["kind"])
        except ValueError:
            raise InputError(f"{key}.kind", f"unknown kind {data['kind']!r}; one of "
                             f"{', '.join(k.value for k in PlatformKind)}") from None
        wheels = data.get("wheels", ())
        if isinstance(wheels, str) or not all(isinstance(w, str) for w in wheels):
            raise InputError(f"{key}.wheels", f"expected a list of joint names, got {wheels!r}")
        wheels = tuple(wheels)
        if kind is PlatformKind.DIFFERENTIAL_DRIVE:
            if len(wheels) != 2 or wheels[0] == wheels[1]:
                raise InputError(f"{key}.wheels", "a differential drive needs two distinct "
                                 f"wheel joints, left first, got {list(wheels)}")
        elif wheels:
            raise InputError(f"{key}.wheels", f"a {kind.value} platform has no wheel coordinates")
        for name in ("wheel_radius", "half_track"):
            if name in data and kind is not PlatformKind.DIFFERENTIAL_DRIVE:
                raise InputError(f"{key}.{name}",
                                 f"only for a differential drive, not {kind.value}")
        radius, track = data.get("wheel_radius"), data.get("half_track")
        box = data.get("box")
        return PlatformSpec(
            kind,
            wheels,
            None if radius is None else _positive(radius, f"{key}.wheel_radius"),
            None if track is None else _positive(track, f"{key}.half_track"),
            None if box is None else PlatformBox.parse(box, f"{key}.box"),
            _positive(data.get("wheel_mass", 1.0), f"{key}.wheel_mass"),
        )


@dataclass(frozen=True)
class Mount:
    """Pose of an arm-only URDF's root frame in the platform frame (on the ground, x forward)."""

    xyz: Vec3 = (0.0, 0.0, 0.0)
    rpy: Vec3 = (0.0, 0.0, 0.0)

    @staticmethod
    def parse(data: Mapping[str, Any] | Mount, key: str = "robot.mount") -> Mount:
        """Validate ``{xyz, rpy}`` (or pass a Mount through)."""
        if isinstance(data, Mount):
            return data
        _check_keys(data, ("xyz", "rpy"), key)
        return Mount(
            _vec3(_vec(data.get("xyz", (0, 0, 0)), f"{key}.xyz")),
            _vec3(_vec(data.get("rpy", (0, 0, 0)), f"{key}.rpy")),
        )


@dataclass(frozen=True)
class CollisionOptions:
    """How collision spheres are fitted to the URDF's collision geometry.

    Attributes:
        tolerance: A sphere may stick out of the geometry it covers by about this much [m]
            (:func:`~mmplan.robot.sphere_fit.fit_spheres`): smaller gives more, tighter spheres.
        spacing: Surface sampling of primitives, mesh edges and wide triangles [m].
        max_spheres_per_body: Upper bound on the spheres of one body (beyond it the last
            spheres grow to cover what is left, sticking out further).
        spheres: Spheres given by hand, by body (``platform``, a wheel link or the child
            link of a moving joint): ``(center in that body's frame [m], radius [m])``. They
            replace the body's fitted spheres (self-collision pairs are chosen after).
    """

    tolerance: float = 0.05
    spacing: float = 0.02
    max_spheres_per_body: int = 200
    spheres: Mapping[str, Sequence[tuple[Vec3, float]]] = field(default_factory=dict)


@dataclass(frozen=True)
class Locked:
    """Values of held joints by URDF joint name [rad or m]."""

    values: Mapping[str, float] = field(default_factory=dict)

    @staticmethod
    def parse(data: Mapping[str, Any] | None, key: str = "robot.locked") -> Locked:
        """Validate ``{joint: value}``."""
        if data is None:
            return Locked()
        if not isinstance(data, Mapping):
            raise InputError(key, f"expected a mapping joint: value, got {data!r}")
        values = {}
        for name, value in data.items():
            try:
                v = float(value)
            except (TypeError, ValueError):
                raise InputError(f"{key}.{name}", f"expected a number, got {value!r}") from None
            if not math.isfinite(v):
                raise InputError(f"{key}.{name}", f"expected a finite number, got {value!r}")
            values[str(name)] = v
        return Locked(values)
