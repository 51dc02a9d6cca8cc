"""Obstacle base class, the registry of shapes by name and symbolic distance helpers.

Every shape (one class per file) is a frozen dataclass whose field names are the keys of its
scenario YAML form (docs/conventions.md), so ``to_dict`` and :func:`obstacle_from_dict` are generic.
Each shape offers two views of the same object (docs/conventions.md):

* :meth:`Obstacle.distance`: the exact signed Euclidean distance (negative inside) used by the
  independent checker, always against the original shape;
* :meth:`Obstacle.superellipsoid`: a smooth Barr superellipsoid model used by planners, a
  :class:`~mmplan.scene.smooth_model.SuperellipsoidModel` (a lower module: the model knows no
  obstacle class).

Planners that need the distance inside a compiled CasADi function (the tracking planners)
use :meth:`Obstacle.signed_distance_sym` (and :meth:`Obstacle.horizontal_distance_sym`): each
shape builds its own expression, so a new shape only touches its own file. Field validation
(``as_float``, ``vector``, ...) and the local frame (``to_local``) are in
:mod:`mmplan.scene.fields`.
"""

from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, Literal, TypeVar

import casadi as ca
from numpy.typing import ArrayLike

from mmplan.errors import InputError, UnknownNameError
from mmplan.scene.fields import Array
from mmplan.scene.smooth_model import SuperellipsoidModel

_REGISTRY: dict[str, type[Obstacle]] = {}

ShapeT = TypeVar("ShapeT", bound="type[Obstacle]")


def register_shape(cls: ShapeT) -> ShapeT:
    """Class decorator: make a shape constructible by :func:`obstacle_from_dict`."""
    _REGISTRY[cls.shape] = cls
    return cls


def shape_names() -> tuple[str, ...]:
    """Names of the registered shapes, sorted."""
    return tuple(sorted(_REGISTRY))


def obstacle_from_dict(data: Mapping[str, Any]) -> Obstacle:
    """Build an obstacle from its scenario form, e.g. ``{shape: sphere, center: [..], radius: r}``.

    Raises:
        UnknownNameError: ``shape`` is missing or not a registered shape.
        InputError: a key is unknown or missing, or a value is invalid (field names the key).
    """
    if not isinstance(data, Mapping):
        raise InputError("", f"an obstacle must be a mapping with a 'shape' key, got {data!r}")
    if "shape" not in data:
        raise InputError("shape", f"missing; one of {', '.join(shape_names())}")
    name = data["shape"]
    if not isinstance(name, str) or name not in _REGISTRY:
        raise UnknownNameError(
            "shape", f"unknown shape {name!r}; one of {', '.join(shape_names())}"
        )
    cls = _REGISTRY[name]
    names = [f.name for f in dataclasses.fields(cls)]  # type: ignore[arg-type]
    kwargs = {k: v for k, v in data.items() if k != "shape"}
    for key in kwargs:
        if key not in names:
            raise InputError(str(key), f"unknown key for shape {name!r}; keys: {', '.join(names)}")
    required = [
        f.name
        for f in dataclasses.fields(cls)  # type: ignore[arg-type]
        if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
    ]
    for key in required:
        if key not in kwargs:
            raise InputError(key, f"missing for shape {name!r}")
    return cls(**kwargs)


@dataclass(frozen=True)
class Solid:
    """An obstacle's true shape for drawing (reports, viewers), in the drawing vocabulary.

    ``kind`` is one of the primitives a viewer knows, or ``"model"`` for "draw my smooth
    superellipsoid model" (:meth:`Obstacle.superellipsoid`), so that adding a shape touches
    only its own file.

    Attributes:
        kind: ``"sphere"`` (size = (radius,)), ``"box"`` (size = full edge lengths (3,)),
            ``"cylinder"`` (size = (radius, height), vertical axis) or ``"model"``.
        size: As above [m]; empty for ``"model"``.
        center: Centre of the solid (3,) [m].
        yaw: Rotation about the vertical axis [rad].
    """

    kind: Literal["sphere", "box", "cylinder", "model"]
    size: tuple[float, ...] = ()
    center: tuple[float, float, float] = (0.0, 0.0, 0.0)
    yaw: float = 0.0


class Obstacle(ABC):
    """A static obstacle. Subclasses are frozen dataclasses validated in ``__post_init__``.

    Attributes:
        shape: Registry name, also the ``shape`` key of the scenario form.
        influence: Planner neighbourhood size [m] from the scenario (measured from the
            enlarged surface); ``None`` means the planner's default.
    """

    shape: ClassVar[str]
    influence: float | None

    @abstractmethod
    def distance(self, points: ArrayLike) -> Array:
        """Exact signed Euclidean distance from each point (P, 3) to the surface (P,) [m].

        Negative inside. Accurate to 1e-6 m.
        """

    @abstractmethod
    def enlarged(self, eps: float) -> Obstacle:
        """The same kind of obstacle grown by ``eps`` [m] (half extents + eps)."""

    @abstractmethod
    def superellipsoid(self) -> SuperellipsoidModel:
        """Smooth superellipsoid model of this obstacle for planners."""

    def solid(self) -> Solid:
        """The true shape for drawing; by default the smooth model (shapes with a primitive
        of their own say so)."""
        return Solid("model")

    @abstractmethod
    def signed_distance_sym(self, p: ca.SX) -> ca.SX:
        """Symbolic signed distance d(p) from a point p (3, 1) to the surface [m], negative inside.

        For planners that need d(q) and its gradient (automatic differentiation) inside one
        compiled control step. Shapes whose exact signed distance has a short closed form
        build that form (the same geometry as :meth:`distance`, continuous everywhere and
        smooth except on the medial axis and at edges, where CasADi returns one of the
        one-sided derivatives); others may return a smooth approximation (the superellipsoid's
        radial distance).
        """

    def horizontal_distance_sym(self, p: ca.SX) -> ca.SX:
        """Distance in the horizontal plane from a point p (3, 1) to the obstacle [m].

        The point is moved to the height of the obstacle's middle (the centre of its
        superellipsoid model) before measuring with :meth:`signed_distance_sym`, so that a
        platform centre (at floor level) sees a post, cylinder or box by its footprint.
        """
        zc = float(self.superellipsoid().center[2])
        return self.signed_distance_sym(ca.vertcat(p[0], p[1], zc))

    def to_dict(self) -> dict[str, Any]:
        """Scenario YAML form (plain lists and floats); ``influence`` only when set."""
        out: dict[str, Any] = {"shape": self.shape}
        for f in dataclasses.fields(self):  # type: ignore[arg-type]
            value = getattr(self, f.name)
            if f.name == "influence" and value is None:
                continue
            out[f.name] = list(value) if isinstance(value, tuple) else value
        return out


# --------------------------------------------------------------------- symbolic helpers

#: Guards sqrt at 0 so that gradients stay finite (distance error < 1e-9 m).
_EPS2 = 1e-18


def norm_sym(v: ca.SX) -> ca.SX:
    """Euclidean norm of a symbolic vector, with a finite gradient at 0 (error < 1e-9 m)."""
    return ca.sqrt(ca.sumsqr(v) + _EPS2)


def excess_distance_sym(excess: Sequence[ca.SX]) -> ca.SX:
    r"""Signed distance of a convex region from its per-axis excesses (box and cylinder).

    .. math:: d = \big|\max(e, 0)\big| + \min\big(\max_i e_i, 0\big)

    with e_i the excess of the point over the region along axis i (negative inside).
    """
    outside = norm_sym(ca.vertcat(*[ca.fmax(e, 0) for e in excess]))
    inside = excess[0]
    for e in excess[1:]:
        inside = ca.fmax(inside, e)
    return outside + ca.fmin(inside, 0)
