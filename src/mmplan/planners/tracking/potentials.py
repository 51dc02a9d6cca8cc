r"""Null-space potentials of the pseudoinverse tracker ([AbdessemedDjebrani] s.2.3).

Both potentials are CasADi expressions in the generalized coordinates q, so that their
gradients dV/dq come from automatic differentiation inside the compiled control step.

The floor z = h (``Scene.ground``) is one more obstacle of V_2, a half-space acting on the
ground spheres only (:mod:`mmplan.robot.ground`): its distance is the height above the floor,
:math:`d_i = p_{i,z}(q) - r_i - h` (:func:`~mmplan.robot.ground.floor_clearance_sym`), with
the same barrier term and the influence ``d0``.
"""

from __future__ import annotations

from collections.abc import Sequence

import casadi as ca
import numpy as np
from numpy.typing import NDArray

from mmplan.planners.tracking.slots import Term
from mmplan.robot.ground import floor_clearance_sym
from mmplan.robot.robot import Robot


def joint_limit_potential(
    q: ca.SX,
    arm_indices: Sequence[int],
    joint_min: NDArray[np.float64],
    joint_max: NDArray[np.float64],
) -> ca.SX:
    r"""Joint-limit potential, [AbdessemedDjebrani] eq. (30), on the arm coordinates.

    .. math:: V_1(q) = \tfrac12 \sum_{i \in arm} \big(q_i - (\bar q_i + \underline q_i)/2\big)^2

    Args:
        q: Symbolic coordinates (n,).
        arm_indices: Positions of the arm coordinates in q (n_a,).
        joint_min, joint_max: Arm limits (n_a,) [rad or m].

    Returns:
        Scalar V_1 [rad^2].
    """
    mid = (np.asarray(joint_min, dtype=float) + np.asarray(joint_max, dtype=float)) / 2.0
    qa = ca.vertcat(*[q[i] for i in arm_indices]) if arm_indices else ca.SX(0, 1)
    return 0.5 * ca.sumsqr(qa - ca.DM(mid))


def barrier_term(d: ca.SX, k1: float, d0: float | ca.SX, d_floor: float) -> ca.SX:
    r"""One term of the obstacle potential, [AbdessemedDjebrani] eq. (32), with a linear floor.

    .. math::
        V_{2i}(d) = \tfrac12 k_1 (1/d - 1/d_0)^2 \ \ (d \le d_0), \qquad 0 \ \ (d > d_0).

    Below ``d_floor`` (and inside an obstacle, d <= 0, where eq. (32) is undefined) the term
    continues along its tangent at ``d_floor``, so that V stays finite and C^1 and its
    gradient keeps pushing outwards with the force it has at ``d_floor``.

    Args:
        d: Distance from a robot point to an obstacle [m] (scalar expression).
        k1: Gain k_1 [m^2].
        d0: Influence distance d_0 [m] (> d_floor).
        d_floor: Distance below which V is extended linearly [m] (> 0).
    """
    inner = 0.5 * k1 * (1.0 / d - 1.0 / d0) ** 2
    v_floor = 0.5 * k1 * (1.0 / d_floor - 1.0 / d0) ** 2
    slope = -k1 * (1.0 / d_floor - 1.0 / d0) / d_floor**2  # dV/dd at d_floor (< 0)
    linear = v_floor + slope * (d - d_floor)
    return ca.if_else(d >= d0, 0, ca.if_else(d >= d_floor, inner, linear))


def sphere_distances(
    points: ca.SX, radii: NDArray[np.float64], terms: Sequence[Term]
) -> list[tuple[Term, ca.SX]]:
    """d_ij = dist(p_i, O_j) - r_i for every collision sphere i and obstacle j.

    dist is each obstacle's own symbolic signed distance (:class:`~.slots.Term`: the
    obstacle's :meth:`~mmplan.scene.obstacle.Obstacle.signed_distance_sym`, or its parametric
    form of :mod:`mmplan.scene.parametric`).

    Args:
        points: Symbolic sphere centres (3, P) in world coordinates.
        radii: Sphere radii (P,) [m].
        terms: The obstacles (:func:`~.slots.baked` or :meth:`~.slots.Slots.terms`).

    Returns:
        (term, d_ij) pairs, obstacle-major.
    """
    return [
        (term, term.distance(points[:, i]) - float(radii[i]))
        for term in terms
        for i in range(points.shape[1])
    ]


def floor_distances(robot: Robot, ground: float | None) -> list[ca.SX]:
    """Heights d_i = z_i - r_i - h of the ground spheres above the floor z = ``ground``, as
    scalar expressions in ``robot.symbols.q`` (none without a floor)."""
    if ground is None:
        return []
    clearance = floor_clearance_sym(robot, ground)  # (G, 1)
    return [clearance[i] for i in range(clearance.shape[0])]


def min_clearance_sym(pairs: Sequence[tuple[Term, ca.SX]], floor: Sequence[ca.SX] = ()) -> ca.SX:
    """Smallest d_ij of :func:`sphere_distances` and of the ``floor`` distances
    (:func:`floor_distances`); 1e3 when there are none."""
    d_min = ca.SX(1e3)
    for d in [term.seen(d) for term, d in pairs] + list(floor):
        d_min = ca.fmin(d_min, d)
    return d_min


def obstacle_potential(
    points: ca.SX,
    radii: NDArray[np.float64],
    terms: Sequence[Term],
    k1: float,
    d0: float,
    d_floor: float,
    floor: Sequence[ca.SX] = (),
) -> tuple[ca.SX, ca.SX]:
    r"""Obstacle potential, [AbdessemedDjebrani] eqs. (31)-(32), over the robot's collision spheres.

    .. math:: V_2(q) = \sum_{i,j} V_{2}\big(d_{ij}(q)\big), \quad
              d_{ij} = \mathrm{dist}(p_i(q), O_j) - r_i

    with p_i the sphere centres, r_i their radii (0 for link points) and O_j the obstacles.
    An obstacle's own ``influence`` (scenario key) replaces ``d0`` when set. The floor adds
    one term per ground sphere, :math:`V_2(d_i)` with its height d_i above the floor and the
    influence ``d0``.

    Args:
        points: Symbolic sphere centres (3, P) in world coordinates.
        radii: Sphere radii (P,) [m].
        terms: The obstacles (:func:`~.slots.baked` or :meth:`~.slots.Slots.terms`).
        k1, d0, d_floor: See :func:`barrier_term`.
        floor: Heights of the ground spheres above the floor (:func:`floor_distances`).

    Returns:
        (V_2, d_min): the potential and the smallest distance d_ij or d_i (the planner's
        clearance; 1e3 when there are no obstacles and no floor).
    """
    pairs = sphere_distances(points, radii, terms)
    total = ca.SX(0)
    for term, d in pairs:
        influence = term.influence if term.influence is not None else d0
        total += term.gate(barrier_term(d, k1, influence, d_floor))
    for d in floor:
        total += barrier_term(d, k1, d0, d_floor)
    return total, min_clearance_sym(pairs, floor)
