r"""Obstacle and floor terms whose geometry is read from the parameter vector p.

A :class:`SlotTerm` is one term of the perturbation K of [PajakPajak] eq. (19),
kappa = ((delta - C)/C)^2 for C < delta, with its numbers in p
(:mod:`~mmplan.planners.extended_jacobian.parameters`):

* a superellipsoid slot: C the radial distance of the sphere centre to the (enlarged) model
  minus the sphere radius, the same operations as
  :meth:`mmplan.scene.smooth_model.SuperellipsoidModel.radial_distance_sym` with centre,
  semi-axes and the yaw's cosine and sine as symbols (the exponents, fixed per slot, keep the
  powers as multiplications);
* the floor z = h: C = z - r - h over the spheres whose height depends on q
  (:func:`mmplan.robot.ground.ground_sphere_indices`), a half-space with the same kappa.

:func:`slot_penalty` sums them over every sphere (the reference the culled compiled step of
:mod:`~mmplan.planners.extended_jacobian.obstacles` is tested against).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from mmplan.arrays import Array
from mmplan.planners.extended_jacobian.parameters import FLOOR, SLOT_SIZE, ParameterLayout, Shape
from mmplan.robot.ground import ground_sphere_indices
from mmplan.robot.robot import Robot
from mmplan.scene.smooth_model import power_sym

_SMOOTH_FLOOR = 1e-150  # as in mmplan.scene.smooth_model (the smoothed |t|^(2/e) terms)
#: C is clamped below at this value [m] (as obstacles.obstacle_penalty).
C_FLOOR = 1e-3
#: Distance [m] added to the culling test's bound (:meth:`SlotTerm.within`): covers the
#: rounding of a group's centre for coordinates up to ~1e6 m (1e-16 of them).
CULL_SLACK = 1e-9


@dataclass(frozen=True)
class SlotTerm:
    """One obstacle slot (``exponents``) or the floor (``exponents`` None), its numbers at
    ``offset`` in p, acting on the spheres ``spheres`` (None: every sphere)."""

    exponents: Shape | None
    offset: int
    spheres: tuple[int, ...] | None = None

    @property
    def size(self) -> int:
        return 2 if self.exponents is None else SLOT_SIZE

    def numbers(self, p: Any) -> Any:
        """This term's part of p (SX or MX)."""
        return p[self.offset : self.offset + self.size]

    def influence(self, prm: ca.SX) -> ca.SX:
        """delta from the term's numbers."""
        return prm[self.size - 1]

    def _local(self, point: ca.SX, prm: ca.SX) -> ca.SX:
        c, s = prm[6], prm[7]  # cos and sin of the yaw (parameters.py)
        d = point - prm[:3]
        return ca.vertcat(c * d[0] + s * d[1], -s * d[0] + c * d[1], d[2])

    def gap(self, point: ca.SX, prm: ca.SX) -> ca.SX:
        """C of a point (3,): radial distance to the superellipsoid, or height above the floor."""
        if self.exponents is None:
            return point[2] - prm[0]
        e1, e2 = self.exponents
        loc = self._local(point, prm)
        u = [loc[i] / prm[3 + i] for i in range(3)]

        def term(t: ca.SX, e: float) -> ca.SX:
            eps = _SMOOTH_FLOOR ** (e / 2.0)
            return power_sym(t**2 + eps**2, 1.0 / e)

        implicit = power_sym(term(u[0], e2) + term(u[1], e2), e2 / e1) + term(u[2], e1)
        norm = ca.sqrt(ca.sumsqr(loc))
        return norm * (1.0 - power_sym(implicit, -e1 / 2.0))

    def within(self, point: ca.SX, prm: ca.SX, reach: float) -> ca.SX:
        """1 where the point may lie within ``reach`` + delta of the term, else 0: wherever
        the point's distance to the model's bounding box (a lower bound of :meth:`gap`; the
        floor: its height itself) is below reach + delta, and a hair beyond
        (:data:`CULL_SLACK`).

        The culling test of every (point group, term) pair, five times a step: compared
        squared, the box's excess clipped at 0 by a comparison (gcc inlines it; ``fmax`` is a
        libm call). The square root is correctly rounded, so fl(sqrt(s)) < b implies s <
        fl(b b): squared, the test is as conservative as with the root (an independent review
        found no counterexample in 36 million pairs over exponents 2^-150 to 2^150). The slack
        covers the group centre's rounding instead: the culled step takes it as one transform
        of the points' mean (:mod:`~mmplan.planners.extended_jacobian.obstacles`), which
        differs from the mean of the transformed points by rounding that grows with the
        coordinates (the review measured up to 3.2e-11 m with the platform 1e5 m from the
        origin; without a slack the test then said 0 for pairs within 3 ulp of the bound).
        Where it says 1 for a far group, the block adds exact zeros.
        """
        bound = reach + self.influence(prm) + CULL_SLACK
        if self.exponents is None:
            return point[2] - prm[0] < bound
        excess = ca.fabs(self._local(point, prm)) - prm[3:6]
        clipped = ca.if_else(excess > 0.0, excess, 0.0)
        return ca.sumsqr(clipped) < bound * bound

    def kappa(self, point: ca.SX, radius: ca.SX, prm: ca.SX) -> ca.SX:
        """((delta - C)/C)^2 for C < delta, else 0, with C = max(gap - radius, C_FLOOR)."""
        C = ca.fmax(self.gap(point, prm) - radius, C_FLOOR)
        delta = self.influence(prm)
        return ca.if_else(delta > C, ((delta - C) / C) ** 2, 0.0)

    def indices(self, count: int) -> list[int]:
        """Spheres this term acts on, out of ``count``."""
        return list(range(count)) if self.spheres is None else list(self.spheres)


def slot_terms(robot: Robot, layout: ParameterLayout) -> list[SlotTerm]:
    """The floor (when the robot has spheres it applies to) and every slot of ``layout``."""
    ground = ground_sphere_indices(robot)
    out = [SlotTerm(None, FLOOR, tuple(ground))] if ground else []
    return out + [SlotTerm(e, at) for e, at in layout.slot_offsets()]


def slot_penalty(
    points: ca.SX, radii: Array, terms: Sequence[SlotTerm], p: ca.SX
) -> ca.SX:
    """K = sum over terms and their spheres of kappa (module docstring), SX.

    Args:
        points: Sphere centres (3, P). radii: Sphere radii (P,). terms: The terms.
        p: The parameter vector (or any vector the terms' offsets index).
    """
    total = ca.SX(0)
    point, radius = ca.SX.sym("point", 3), ca.SX.sym("radius")
    radii = np.asarray(radii, dtype=float)
    for t in terms:
        idx = t.indices(points.shape[1])
        if not idx:
            continue
        prm = ca.SX.sym("prm", t.size)
        # one expression per term, mapped over the spheres (fast to build)
        fn = ca.Function("kappa", [point, radius, prm], [t.kappa(point, radius, prm)])
        total += ca.sum2(fn.map(len(idx))(points[:, idx], ca.DM(radii[idx]).T, t.numbers(p)))
    return total
