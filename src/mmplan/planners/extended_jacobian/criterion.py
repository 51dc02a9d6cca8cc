r"""Symbolic core of the extended-Jacobian generator ([PajakPajak], [Pajak]).

Everything here is a CasADi SX expression in the robot's symbols ``q`` (n,), ``dq`` (n,)
and a goal parameter ``p_f`` (3,); derivatives come from CasADi AD, never by hand.

* Criterion, [PajakPajak] eq. (9), [Pajak] eq. (8):
  :math:`H(q) = -\mu(q_a) + \sum_i w/(q_i - q_{i,min}) + w/(q_{i,max} - q_i)` over the arm
  joints (our choice, see docs/extended_jacobian.md: the penalty acts over the whole range,
  otherwise q1 is undetermined because mu does not depend on it and E is singular at the goal).
  Real robots (docs/extended_jacobian.md, Real robots): mu at the wrist centre
  (:mod:`~mmplan.planners.extended_jacobian.wrist`), a posture term on redundant arms and a
  heading term on omnidirectional platforms (:mod:`~mmplan.planners.extended_jacobian.posture`);
  none of them applies to the papers' youBots.
* Transversality, [PajakPajak] eq. (11), [Pajak] eq. (9), with the stacked Jacobian Jc = [J; A]
  (m+h, n) split into columns R (m+h) and F (n-m-h):
  :math:`g(q) = H_F - (Jc_R^{-1} Jc_F)^T H_R`; by default in the cheaper equal form of
  :mod:`mmplan.planners.extended_jacobian.structure` (3-4x fewer operations in the compiled step),
  the
  symbolic (m+h) solve with the robot's mu being the reference (``structured=False``).
* Errors e_I = [k(q) - p_f; g(q)] (n-h,), e_II = A(q) dq (h,).
* E = [de_I/dq; A] (n, n), v1 = [d/dt(de_I/dq) dq; d/dt(A) dq],
  v2 = [Lambda_V de_I/dq dq + Lambda_P e_I; Lambda_II A dq], so that [PajakPajak] eq. (16), [Pajak]
  eq. (12) reads ddq = -E^{-1}(v1 + v2).

Partition rule (our choice, see docs/extended_jacobian.md: R must not contain the whole arm
Jacobian, or Jc_R^-1 holds its inverse and the run diverges near arm singularities): R holds every
platform coordinate (the wheel angles make A's columns invertible) plus the
m + h - n_platform arm joints whose choice gives the best-conditioned Jc_R at the start
q0; ties go to the earlier joint. When no such R is invertible (an omnidirectional
platform, h = 0: x, y, theta move the end effector only in the plane), R holds as many
platform coordinates as possible (ur5-omni: x, y and shoulder_lift_joint). For youbot-3r
this selects R = {x, y, theta, phi1, phi2, q2} and F = {q1, q3}, the partition of
[RefRuns].
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from mmplan import linalg
from mmplan.arrays import Array
from mmplan.errors import InputError
from mmplan.planners.extended_jacobian.posture import heading_term, posture_term
from mmplan.planners.extended_jacobian.structure import (
    partition_selection,
    reduced_manipulability,
    selectable,
    selected_transversality,
    structured_transversality,
)
from mmplan.planners.extended_jacobian.wrist import find_wrist, wrist_jacobian
from mmplan.robot.robot import Robot
from mmplan.robot.tree import JointKind


@dataclass(frozen=True)
class Partition:
    """Column partition of Jc = [J; A]: indices of R (m+h,) and F (n-m-h,), robot order."""

    R: tuple[int, ...]
    F: tuple[int, ...]

    def names(self, robot: Robot) -> tuple[tuple[str, ...], tuple[str, ...]]:
        """Coordinate names of R and F."""
        return tuple(robot.coordinates[i] for i in self.R), tuple(
            robot.coordinates[i] for i in self.F
        )


def stacked_jacobian(robot: Robot, q: Array) -> Array:
    """Jc(q) = [J(q); A(q)], (3 + h, n)."""
    return np.vstack([robot.jacobian(q), robot.pfaffian(q)])


def choose_partition(robot: Robot, q0: Array) -> Partition:
    """Partition rule of this module: platform coordinates plus the best arm joints in R.

    Raises:
        InputError: no choice gives an invertible Jc_R at ``q0`` (start at a singularity).
    """
    n, m, h = robot.n, 3, robot.h
    n_r = m + h
    if n_r > n:
        raise InputError("robot", f"{robot.name}: cannot partition {n} columns into R of {n_r}")
    Jc = stacked_jacobian(robot, q0)
    # As many platform columns as keep Jc_R invertible: all of them for wheeled platforms
    # (A needs the wheel angles); an omnidirectional platform (h = 0) cannot move the end
    # effector vertically, so x, y, theta and nothing else is singular: one platform column
    # (theta, dependent on x and y in the plane) then goes to F.
    revolute = tuple(i for i in robot.arm_indices if not _prismatic(robot, i))
    for keep in range(min(robot.n_platform, n_r), -1, -1):
        best: tuple[float, tuple[int, ...]] | None = None
        for platform in itertools.combinations(range(robot.n_platform), keep):
            arms = itertools.chain(
                itertools.combinations(revolute, n_r - keep),
                (c for c in itertools.combinations(robot.arm_indices, n_r - keep)
                 if not set(c) <= set(revolute)),
            )
            for arm in arms:
                R = platform + arm
                cond = linalg.cond(Jc[:, list(R)])
                if not set(arm) <= set(revolute):
                    cond *= PRISMATIC_IN_R  # only when no revolute choice is near as good
                if np.isfinite(cond) and (best is None or cond < 0.999 * best[0]):
                    best = (cond, R)
        if best is not None and best[0] <= 1e10:
            R = best[1]
            return Partition(R, tuple(i for i in range(n) if i not in R))
    raise InputError(
        "start", f"Jc_R is singular at the start for every partition of {robot.name}"
    )


#: A prismatic arm joint enters R only when every choice of revolute joints is this many times
#: worse conditioned (docs/extended_jacobian.md, Real robots: TIAGo's torso).
PRISMATIC_IN_R = 100.0


def _prismatic(robot: Robot, index: int) -> bool:
    name = robot.coordinates[index]
    joint = next(j for j in robot.tree.joints if j.coordinate == name)
    return joint.kind is JointKind.PRISMATIC


def repartition(
    robot: Robot, q: Array, current: Partition, factor: float = 0.1
) -> Partition | None:
    """Best-conditioned Jc_R over all column choices at q, if ``factor`` times better
    conditioned than ``current`` (10x by default).

    Used when cond(E) grows along a run (e.g. youbot-3r with the end effector sideways of
    the platform centre, where every R holding all platform columns is singular; the
    triggers: :mod:`~mmplan.planners.extended_jacobian.switching`). The zero set of g, and
    with it the planned optimum, does not depend on the partition (eq. (11)). Prismatic arm
    joints count :data:`PRISMATIC_IN_R` times worse, as in :func:`choose_partition`.
    """
    Jc = stacked_jacobian(robot, q)
    n_r = Jc.shape[0]
    now = linalg.cond(Jc[:, list(current.R)])
    prismatic = {i for i in robot.arm_indices if _prismatic(robot, i)}
    best: tuple[float, tuple[int, ...]] | None = None
    for R in itertools.combinations(range(robot.n), n_r):
        cond = linalg.cond(Jc[:, list(R)])
        if prismatic & set(R):
            cond *= PRISMATIC_IN_R
        if np.isfinite(cond) and (best is None or cond < best[0]):
            best = (cond, R)
    if best is None or not best[0] < factor * now:
        return None
    return Partition(best[1], tuple(i for i in range(robot.n) if i not in best[1]))


@dataclass(frozen=True)
class Criterion:
    """Symbolic generator quantities (SX) of one robot, partition and penalty weight.

    Attributes:
        q, dq, p_f: Symbols (n,), (n,), (3,).
        H: Criterion (1,). g: Transversality (n-m-h,). e_I: Task error (n-h,).
        De: de_I/dq (n-h, n). E: [De; A] (n, n). v1: (n,). v2_parts: (De dq, e_I, A dq),
            so v2 = [Lambda_V De dq + Lambda_P e_I; Lambda_II A dq].
    """

    q: ca.SX
    dq: ca.SX
    p_f: ca.SX
    H: ca.SX
    g: ca.SX
    e_I: ca.SX  # noqa: N815
    De: ca.SX
    E: ca.SX
    v1: ca.SX
    de_I: ca.SX  # noqa: N815
    e_II: ca.SX  # noqa: N815
    #: Partition symbols [sigma; vec(S_F)] (n_a^2,) when the partition is a parameter
    #: (:mod:`~mmplan.planners.extended_jacobian.parameters`), else empty (0,).
    sel: ca.SX = field(default_factory=lambda: ca.SX(0, 1))
    #: Heading reference symbol (1,) when the heading term's theta_ref is a parameter, else (0,).
    theta: ca.SX = field(default_factory=lambda: ca.SX(0, 1))
    #: Arm joints the parametric partition may put in R (robot indices; empty: built in).
    choices: tuple[int, ...] = ()


def joint_limit_penalty(q_arm: ca.SX, q_min: Array, q_max: Array, weight: float) -> ca.SX:
    """sum_i w/(q_i - q_min,i) + w/(q_max,i - q_i), arm joints i (docs/extended_jacobian.md)."""
    terms = [
        weight / (q_arm[i] - q_min[i]) + weight / (q_max[i] - q_arm[i])
        for i in range(q_arm.numel())
    ]
    return ca.sum1(ca.vertcat(*terms))


def build_criterion(
    robot: Robot,
    partition: Partition,
    weight: float = 0.01,
    structured: bool = True,
    posture: Array | None = None,
    heading: float | None = None,
    parametric: bool = False,
) -> Criterion:
    """Build H, g, e_I, E, v1 for ``robot`` ([PajakPajak] eqs. (9)-(16)).

    With ``structured`` (default) mu and g take the cheaper equal forms of
    :mod:`mmplan.planners.extended_jacobian.structure` (same values up to rounding, checked at two
    seeded
    states; 3-10x fewer operations in g, E and v1); ``structured=False`` is the
    straightforward reference: mu from the robot and g with the symbolic (m+h) solve.
    ``posture`` holds the weights beta_i of the posture term (None or zeros: none, the
    papers' criterion);
    ``heading`` theta_ref of the heading term for a platform whose heading the rest leaves
    undetermined (None: no term; :mod:`~mmplan.planners.extended_jacobian.posture`). mu is
    measured at the wrist centre when the arm has one
    (:mod:`~mmplan.planners.extended_jacobian.wrist`), else at the end effector.
    With ``parametric`` the heading reference and, where the structure allows it
    (:func:`~mmplan.planners.extended_jacobian.structure.selected_transversality`), the
    partition are symbols (``theta``, ``sel``; ``partition`` is then only the one the guard
    checks the structured form with).
    """
    s = robot.symbols
    q, dq = s.q, s.dq
    p_f = ca.SX.sym("p_f", 3)
    q_arm = q[list(robot.arm_indices)]
    penalty = joint_limit_penalty(q_arm, robot.limits.joint_min, robot.limits.joint_max, weight)
    if posture is not None and np.any(np.asarray(posture) > 0.0):
        penalty += posture_term(q_arm, robot.limits.joint_min, robot.limits.joint_max, posture)
    theta = ca.SX.sym("theta_ref") if parametric and heading is not None else ca.SX(0, 1)
    if heading is not None:
        penalty += heading_term(q, theta if theta.numel() else heading)
    wrist = find_wrist(robot)
    J_w = None if wrist is None else wrist_jacobian(robot, wrist)
    mu = s.manipulability if J_w is None else ca.sqrt(ca.fmax(ca.det(J_w @ J_w.T), 0))
    H = -mu + penalty
    g = reference_transversality(robot, partition, H)
    if structured:
        H_red = -reduced_manipulability(robot, J_w) + penalty
        g_red = structured_transversality(robot, partition.R, partition.F, ca.gradient(H_red, q))
        if g_red is None:  # R without every platform column: the solve, with the cheaper mu
            g_red = reference_transversality(robot, partition, H_red)
        sel = ca.SX(0, 1)
        if parametric:
            n_a = len(robot.arm_indices)
            sel = ca.SX.sym("sel", n_a * n_a)
            found = selected_transversality(
                robot, sel[:n_a], ca.reshape(sel[n_a:], n_a, n_a - 1), ca.gradient(H_red, q)
            )
            if found is not None and selectable(robot, partition.R, found[1]):
                g_sel, choices = found
                n_p = robot.n_platform
                chosen = partition_selection(n_p, len(robot.arm_indices), partition)
                g_red = ca.substitute(g_sel, sel, ca.DM(chosen))
                if _agree(q, p_f, g, g_red, robot, theta=theta, value=heading):
                    e_I = ca.vertcat(s.ee_position - p_f, ca.cse(g_sel))
                    return _finish(robot, q, dq, p_f, H_red, g_sel, e_I, sel, theta, choices)
        if _agree(q, p_f, g, g_red, robot, theta=theta, value=heading):
            H, g = H_red, ca.cse(g_red)
    e_I = ca.vertcat(s.ee_position - p_f, g)
    return _finish(robot, q, dq, p_f, H, g, e_I, ca.SX(0, 1), theta)


def _finish(
    robot: Robot,
    q: ca.SX,
    dq: ca.SX,
    p_f: ca.SX,
    H: ca.SX,
    g: ca.SX,
    e_I: ca.SX,
    sel: ca.SX,
    theta: ca.SX,
    choices: tuple[int, ...] = (),
) -> Criterion:
    """The criterion's derived quantities (E, v1, ...) from e_I."""
    De = ca.jacobian(e_I, q)
    A = robot.symbols.pfaffian
    E = ca.vertcat(De, A)
    de_I = De @ dq
    e_II = A @ dq
    v1 = ca.vertcat(ca.jacobian(de_I, q) @ dq, ca.jacobian(e_II, q) @ dq)
    return Criterion(q, dq, p_f, H, g, e_I, De, E, v1, de_I, e_II, sel, theta, choices)


def reference_transversality(robot: Robot, partition: Partition, H: ca.SX) -> ca.SX:
    """g = H_F - (Jc_R^-1 Jc_F)^T H_R ([PajakPajak] eq. (11)) with a symbolic solve (reference)."""
    s = robot.symbols
    Hq = ca.gradient(H, s.q)
    Jc = ca.vertcat(s.jacobian, s.pfaffian)
    R, F = list(partition.R), list(partition.F)
    X = ca.solve(Jc[:, R], Jc[:, F])  # Jc_R^-1 Jc_F, (m+h, n-m-h)
    return Hq[F] - X.T @ Hq[R]


def _agree(
    q: ca.SX,
    p_f: ca.SX,
    g: ca.SX,
    g_red: ca.SX,
    robot: Robot,
    states: int = 2,
    theta: ca.SX | None = None,
    value: float | None = None,
) -> bool:
    """Guard: the structured g equals the reference at a few seeded random states."""
    if theta is not None and theta.numel():
        g, g_red = (ca.substitute(x, theta, value or 0.0) for x in (g, g_red))
    fn = ca.Function("g_check", [q, p_f], [g, g_red])
    rng = np.random.default_rng(0)
    lo = np.where(np.isfinite(robot.limits.joint_min), robot.limits.joint_min, -np.pi)
    hi = np.where(np.isfinite(robot.limits.joint_max), robot.limits.joint_max, np.pi)
    for _ in range(states):
        x = rng.uniform(-1.0, 1.0, robot.n)
        x[list(robot.arm_indices)] = lo + (hi - lo) * rng.uniform(0.2, 0.8, len(lo))
        ref, red = (np.asarray(v, dtype=float).ravel() for v in fn(x, [0.7, -0.4, 0.5]))
        if not np.allclose(red, ref, rtol=1e-8, atol=1e-8 * max(1.0, float(np.abs(ref).max()))):
            return False
    return True


def generator_terms(crit: Criterion, gains: Sequence[float], h: int) -> tuple[ca.SX, ca.SX]:
    """Drift and feedback parts of eq. (16): ddq = f0 + u fv with f0 = -E^-1 v1, fv = -E^-1 v2.

    Args:
        crit: Symbolic criterion.
        gains: (Lambda_P, Lambda_V, Lambda_II) scalars (or SX symbols).
        h: Number of Pfaffian rows.
    """
    lam_p, lam_v, lam_ii = gains
    v2 = ca.vertcat(lam_v * crit.de_I + lam_p * crit.e_I, lam_ii * crit.e_II)
    f0 = -ca.solve(crit.E, crit.v1)
    fv = -ca.solve(crit.E, v2)
    return f0, fv
