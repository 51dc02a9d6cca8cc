"""The scene as numbers for the tracking planners' compiled steps (docs/tracking.md).

A tracker's obstacle terms come from :class:`Term`\\ s: an obstacle's signed distance, its
footprint distance (of a point at floor level) and its influence distance. :func:`baked` makes
them from the scene's obstacles (their numbers built into the expressions, any shape);
:class:`Slots` makes them from a parameter vector with a fixed number of slots per shape kind
(:mod:`mmplan.scene.parametric`: spheres, cylinders, boxes), so one compiled step serves every
scene with those kinds and at most those counts: obstacle centres, sizes, yaw and influence
distances are numbers in its input (``Slots.pack``); an unused slot parks its obstacle 1 km
away and switches its terms off by its active flag (a review: the impedance force measures a
footprint at the obstacle's own height, so a parked post at (1000, 1000) pushed a robot planned
near there by 0.5 m). Counts are rounded up to a multiple of ``SLOT_STEP``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from mmplan.arrays import Array
from mmplan.scene import parametric

#: Slots of a kind come in multiples of this.
SLOT_STEP = 2


@dataclass(frozen=True)
class Term:
    """One obstacle as a tracker sees it.

    Attributes:
        distance: Signed distance of a point p (3, 1) [m].
        horizontal: Distance of a point at floor level to the obstacle's footprint [m].
        influence: Influence distance [m] (None: the planner's default).
    """

    distance: Callable[[ca.SX], ca.SX]
    horizontal: Callable[[ca.SX], ca.SX]
    influence: float | ca.SX | None
    active: ca.SX | None = None  # a slot's 1 (an obstacle) or 0 (parked); None: always on

    def gate(self, value: ca.SX) -> ca.SX:
        """``value`` (a potential or a force) where the obstacle is, 0 for a parked slot (x 1
        exactly: the same bits as without the gate)."""
        return value if self.active is None else self.active * value

    def seen(self, d: ca.SX) -> ca.SX:
        """A distance ``d`` for the clearance, 1e3 m for a parked slot."""
        return d if self.active is None else ca.if_else(self.active > 0.5, d, 1e3)


def baked(obstacles: Sequence[Any]) -> list[Term]:
    """Terms with the obstacles' numbers built in (every shape)."""
    return [
        Term(ob.signed_distance_sym, ob.horizontal_distance_sym, ob.influence) for ob in obstacles
    ]


@dataclass(frozen=True)
class Slots:
    """Slots per shape kind, (kind, count) sorted by kind."""

    kinds: tuple[tuple[str, int], ...]

    @classmethod
    def of(cls, obstacles: Sequence[Any]) -> Slots | None:
        """The slots for these obstacles (None: one has no parametric form)."""
        counts: dict[str, int] = {}
        for ob in obstacles:
            kind = parametric.kind_of(ob)
            if kind is None:
                return None
            counts[kind] = counts.get(kind, 0) + 1
        return cls(
            tuple((k, SLOT_STEP * math.ceil(c / SLOT_STEP)) for k, c in sorted(counts.items()))
        )

    @property
    def size(self) -> int:
        """Numbers of the parameter vector: each slot's geometry, influence and active flag."""
        return sum(k * (parametric.SIZES[kind] + 2) for kind, k in self.kinds)

    def accepts(self, obstacles: Sequence[Any]) -> bool:
        """These obstacles fit in the slots."""
        need = Slots.of(obstacles)
        have = dict(self.kinds)
        return need is not None and all(have.get(e, 0) >= k for e, k in need.kinds)

    def terms(self, p: ca.SX) -> list[Term]:
        """The slots' terms read from the parameter symbol ``p`` (size :attr:`size`)."""
        out, at = [], 0
        for kind, count in self.kinds:
            n = parametric.SIZES[kind]
            for _ in range(count):
                g, influence, active = p[at : at + n], p[at + n], p[at + n + 1]
                out.append(Term(_distance(kind, g), _horizontal(kind, g), influence, active))
                at += n + 2
        return out

    def pack(self, obstacles: Sequence[Any], influence: float) -> Array:
        """The parameter vector of these obstacles (``influence``: for those without their own
        and for the parked slots)."""
        if not self.accepts(obstacles):
            raise ValueError(f"{len(obstacles)} obstacles do not fit the slots {self.kinds}")
        out: list[float] = []
        for kind, count in self.kinds:
            mine = [ob for ob in obstacles if parametric.kind_of(ob) == kind]
            for j in range(count):
                if j < len(mine):
                    ob = mine[j]
                    own = ob.influence if ob.influence is not None else influence
                    out += [*parametric.geometry(ob), float(own), 1.0]
                else:
                    out += [*parametric.parked(kind), float(influence), 0.0]
        return np.asarray(out, dtype=float)


def _distance(kind: str, g: ca.SX) -> Callable[[ca.SX], ca.SX]:
    return lambda point: parametric.distance_sym(kind, point, g)


def _horizontal(kind: str, g: ca.SX) -> Callable[[ca.SX], ca.SX]:
    def at_footprint(point: ca.SX) -> ca.SX:
        return parametric.distance_sym(
            kind, ca.vertcat(point[0], point[1], parametric.middle_z(kind, g)), g
        )

    return at_footprint
