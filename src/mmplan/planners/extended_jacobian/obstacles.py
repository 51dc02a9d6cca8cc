r"""Obstacle terms of the generator with exact culling ([PajakPajak] eqs. (17)-(19); speed).

The perturbation sums kappa_o(C) = ((delta - C)/C)^2 over every (collision point, obstacle)
pair, 0 where C >= delta (:func:`obstacle_penalty`). On youbot3r-obstacles that is
46 points x 3 obstacles, about 70 % of the operations of a generator step, although the
robot is near one obstacle at a time and then only with a few points. Here the points are
grouped (per body, at most ``GROUP_SIZE`` a group) and the block of one group and one
obstacle (its K and dK/dq) is evaluated only when the group's bounding sphere comes within
delta of the obstacle's bounding box, by a conditional call (``if_else`` with short
circuit, a CasADi ``Switch``):

* the superellipsoid lies in its local box |x'| <= a1, |y'| <= a2, |z'| <= a3 (exponents
  <= 2), and the radial distance C is at least the Euclidean distance to the surface, hence
  at least the distance to the box; if the sphere around a group is at least delta from the
  box, every kappa of the group and its gradient are exactly 0. Culling is exact: the same
  values as the full sum to rounding (tested), not an approximation.
* ``obstacle_terms(q, p) -> (S, fp, dK/dq)``, S = varrho K and fp = P (-varrho G dK/dq)
  (after :mod:`~mmplan.planners.extended_jacobian.near_goal`, which needs the goal in p) as
  in :mod:`~mmplan.planners.extended_jacobian.generator`, the push computed only when some
  block is near; ``obstacle_damping(q, p) -> S``. The obstacles are slots whose geometry is
  read from p, and the floor (:mod:`~mmplan.planners.extended_jacobian.slots`); a block
  function serves every slot of its shape type (one copy of its C code).

Measured (CPU time of one compiled step on youbot3r-obstacles-torque, same run, dt 10 ms;
``python bench/bench_extended_jacobian.py``): 28.6 us full vs 8.9 us culled near the start
(inside obstacle 1's neighbourhood), 8.0 us in free space, 17-20 us between all three
obstacles (MX call overhead: about 2 us a step).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import casadi as ca
import numpy as np

from mmplan.arrays import Array
from mmplan.planners.extended_jacobian.parameters import Shape
from mmplan.planners.extended_jacobian.slots import SlotTerm, slot_penalty
from mmplan.robot.robot import Robot

#: Largest number of collision points in one culled block (:func:`point_groups`).
GROUP_SIZE = 10


class SmoothObstacle(Protocol):
    """What the generator needs of an obstacle model (a scene ``SuperellipsoidModel``)."""

    def radial_distance_sym(self, p: ca.SX) -> ca.SX:
        """Radial distance C from the point p (3,) to the surface, SX scalar."""
        ...

    def radial_distance(self, points: Array) -> Array:
        """The same for points (P, 3) in NumPy, (P,)."""
        ...


@dataclass(frozen=True)
class ObstacleTerm:
    """One obstacle for the perturbation: its smooth (already enlarged) model and delta [m]."""

    model: SmoothObstacle
    influence: float


def obstacle_penalty(
    points: ca.SX,
    obstacles: Sequence[ObstacleTerm],
    c_floor: float = 1e-3,
    radii: Array | None = None,
) -> ca.SX:
    """K = sum_{o, points} kappa_o(C) with kappa_o = ((delta - C)/C)^2 for C < delta, else 0.

    Args:
        points: Collision points (3, P): sphere centres.
        obstacles: Obstacles with their neighbourhood delta.
        c_floor: C is clamped below at this value [m] (the barrier is then ~(delta/c_floor)^2).
        radii: Sphere radii (P,) [m]: C is the radial distance of the centre minus the radius
            (the gap of the sphere's surface along the ray). None or all zero: points
            ([PajakPajak]'s collision points; the youBot models). A URDF robot's spheres are
            up to 0.19 m (TIAGo's platform): as points the obstacle term let them into the
            obstacles.
    """
    total = ca.SX(0)
    point = ca.SX.sym("point", 3)
    radius = ca.SX.sym("radius")
    spheres = radii is not None and bool(np.any(np.asarray(radii) > 0.0))
    for ob in obstacles:
        # One expression per obstacle, mapped over the points (same operations, ~40x faster
        # to build than one Python-level expression per point).
        gap = ob.model.radial_distance_sym(point)
        if spheres:
            gap = gap - radius
        C = ca.fmax(gap, c_floor)
        kappa = ca.if_else(ob.influence > C, ((ob.influence - C) / C) ** 2, 0.0)
        if spheres:
            per_sphere = ca.Function("kappa", [point, radius], [kappa]).map(points.shape[1])
            total += ca.sum2(per_sphere(points, ca.DM(np.asarray(radii, dtype=float)).T))
        else:
            per_point = ca.Function("kappa", [point], [kappa]).map(points.shape[1])
            total += ca.sum2(per_point(points))
    return total


def box_gap_sym(model: Any, point: ca.SX) -> ca.SX:
    """Distance from the point (3,) to the model's bounding box in its local frame, SX."""
    center = np.asarray(model.center, dtype=float)
    axes = np.asarray(model.semi_axes, dtype=float)
    yaw = float(getattr(model, "yaw", 0.0))
    c, s = np.cos(yaw), np.sin(yaw)
    d = point - ca.DM(center)
    local = ca.vertcat(c * d[0] + s * d[1], -s * d[0] + c * d[1], d[2])
    out = ca.fmax(ca.fabs(local) - ca.DM(axes), 0.0)
    return ca.sqrt(ca.sumsqr(out))


def conditional(
    name: str,
    cond: ca.MX,
    fn: ca.Function,
    args: Sequence[ca.MX],
    fallback: ca.Function | None = None,
) -> ca.MX:
    """fn(*args) where ``cond`` (0 or 1) holds, else fallback(*args) (zeros by default).

    A CasADi ``Switch`` on explicit inputs: only the taken branch runs. (``if_else`` with
    short circuit builds the branch from the symbolic primitives, so an input computed from q
    would be recomputed inside the branch: measured 2x slower steps.)
    """
    if fallback is None:
        fallback = ca.Function(name + "_zero", fn.mx_in(), [ca.MX.zeros(fn.sparsity_out(0))])
    out: ca.MX = ca.Function.if_else(name, fn, fallback)(cond, *args)
    return out


def _keep(fn: ca.Function) -> ca.Function:
    """(.., acc) -> acc: the far branch of a block that adds its terms to acc (its last
    input)."""
    ins = fn.mx_in()
    return ca.Function(fn.name() + "_keep", ins, [ins[-1]])


def point_groups(robot: Robot, size: int = GROUP_SIZE) -> list[list[int]]:
    """Collision points grouped per body, each body's points split by recursive bisection
    along their longest extent (body frame) into groups of at most ``size``."""
    groups: list[list[int]] = []
    bodies: dict[str, list[int]] = {}
    for i, sphere in enumerate(robot.collision):
        bodies.setdefault(sphere.body, []).append(i)

    def split(idx: list[int]) -> None:
        if len(idx) <= size:
            groups.append(idx)
            return
        pts = np.array([robot.collision[i].center for i in idx], dtype=float)
        axis = int(np.argmax(pts.max(axis=0) - pts.min(axis=0)))
        order = [idx[k] for k in np.argsort(pts[:, axis], kind="stable")]
        half = len(order) // 2
        split(order[:half])
        split(order[half:])

    for idx in bodies.values():
        split(idx)
    return groups


def obstacle_functions(
    robot: Robot,
    terms: Sequence[SlotTerm],
    n_params: int,
    projector: ca.SX,
    weights: np.ndarray,
    varrho: float,
    finish: Callable[[ca.MX, ca.MX, ca.MX, ca.MX], ca.MX] | None = None,
) -> tuple[ca.Function, ca.Function]:
    """``obstacle_terms(q, p) -> (S, fp, dK/dq)`` and ``obstacle_damping(q, p) -> S`` with
    culling.

    The collision points are grouped (:func:`point_groups`); a group's block for one term
    (an obstacle slot or the floor, :mod:`~mmplan.planners.extended_jacobian.slots`, its
    geometry read from p) is evaluated when the group's bounding sphere (centre = mean of its
    points, a rigid-body point; radius = largest distance of a point from it, plus the
    point's sphere radius) comes within delta of the term's bounding box (the floor: of the
    plane): otherwise no point of the group is within delta, and its kappa and gradient are
    exactly 0. A parked slot (delta = 0, far away) is never evaluated.

    Args:
        robot: The robot (collision points).
        terms: Obstacle slots and the floor.
        n_params: Length of p.
        projector: P(q) (n, n), the wheel-metric projector into ker A.
        weights: G (n,), gradient weight per coordinate.
        varrho: Perturbation gain.
        finish: (q, p, fp_raw, K) -> the push as applied
            (MX; :mod:`~mmplan.planners.extended_jacobian.near_goal`),
            evaluated with the projection only when some block is near (else fp = 0).
    """
    s = robot.symbols
    q, points, n = s.q, s.collision_points, robot.n
    radii = np.asarray(robot.collision_radii, dtype=float)
    qm, pm = ca.MX.sym("q", n), ca.MX.sym("p", n_params)
    ps = ca.SX.sym("p", n_params)
    blocks: list[tuple[int, list[int], SlotTerm]] = []  # (group, spheres, term)
    tests = []
    for g, group in enumerate(point_groups(robot)):
        for t in terms:
            idx = [i for i in group if i in set(t.indices(len(robot.collision)))]
            if not idx:
                continue
            local = np.array([robot.collision[i].center for i in idx], dtype=float)
            radius = float(
                max(
                    np.linalg.norm(c - local.mean(axis=0)) + radii[i]
                    for c, i in zip(local, idx, strict=True)
                )
            )
            # the group's mean point as a point of its body: one transform (the mean of the
            # points' own transforms cost ~18 operations a point)
            T = s.transforms[robot.collision[idx[0]].body]
            centre = T[:3, :3] @ ca.DM(local.mean(axis=0)) + T[:3, 3]
            prm = t.numbers(ps)
            tests.append(t.within(centre, prm, radius))
            blocks.append((g, idx, t))
    total: ca.MX = ca.MX.zeros(n + 1)  # [S; dK/dq] summed over the blocks
    S_only: ca.MX = ca.MX(0)
    if blocks:
        near = ca.Function("mmplan_obstacles_near", [q, ps], ca.cse([ca.vertcat(*tests)]))(qm, pm)
    # one block function per (group, shape type), called for every slot of that type: the
    # C code holds each once, so the build time does not grow with the number of slots
    made: dict[tuple[int, Shape | None], tuple[ca.Function, ca.Function]] = {}
    for b, (g, idx, t) in enumerate(blocks):
        if (g, t.exponents) not in made:
            prm = ca.SX.sym("prm", t.size)
            K = slot_penalty(points[:, idx], radii[idx], [SlotTerm(t.exponents, 0)], prm)
            name = f"mmplan_obst_g{g}_s{len(made)}"
            acc, acc_k = ca.SX.sym("acc", n + 1), ca.SX.sym("acc_k")
            made[g, t.exponents] = (
                ca.Function(name, [q, prm, acc], ca.cse([acc + ca.vertcat(K, ca.gradient(K, q))])),
                ca.Function(name + "_k", [q, prm, acc_k], ca.cse([acc_k + K])),
            )
        block, value = made[g, t.exponents]
        name = f"mmplan_obst_g{g}_t{b}"
        args = [qm, t.numbers(pm)]
        # the sums run through the blocks: a far block passes them on (one copy), where a
        # block of zeros cost a copy of its zeros, a slice and a sum (the chunk 0.87 of
        # that code's time, paired; the same values: acc + 0 is acc)
        total = conditional(name + "_if", near[b], block, [*args, total], _keep(block))
        S_only = conditional(name + "_k_if", near[b], value, [*args, S_only], _keep(value))
    S_total, grad = total[0], total[1:]
    # The push P (-varrho G dK/dq), as ``finish`` changes it, only when some block is near.
    grad_s = ca.SX.sym("grad", n)
    raw = ca.Function(
        "mmplan_obstacle_push_raw", [q, grad_s], [projector @ (-varrho * (ca.DM(weights) * grad_s))]
    )
    ins = [ca.MX.sym("q", n), ca.MX.sym("p", n_params), ca.MX.sym("grad", n), ca.MX.sym("K")]
    fp_in = raw(ins[0], ins[2])
    if finish is not None:
        fp_in = finish(ins[0], ins[1], fp_in, ins[3])
    push = ca.Function("mmplan_obstacle_push", ins, [fp_in])
    if blocks:
        fp = conditional("mmplan_obstacle_push_if", ca.mmax(near), push, [qm, pm, grad, S_total])
    else:  # no collision point or no term: nothing pushes
        fp = ca.MX.zeros(n)
    terms_fn = ca.Function("mmplan_obstacle_terms", [qm, pm], [varrho * S_total, fp, grad])
    damping = ca.Function("mmplan_obstacle_damping", [qm, pm], [varrho * S_only])
    return terms_fn, damping
