r"""Cheaper equal forms of the extended-Jacobian criterion (speed; [PajakPajak] eqs. (5)-(16)).

Every later quantity of the generator (E = [de_I/dq; A], v1 with third derivatives of the
kinematics, four evaluations per RK4 step) is derived by AD from mu and the transversality
g, so their operation counts multiply. The forms here have the same values as the
straightforward ones up to rounding, with 3-10x fewer operations:

* :func:`reduced_manipulability`: mu does not depend on coordinates that move the whole arm
  rigidly (planar pose, the arm's base joint): they are set to 0; det(J J^T) = det(J)^2 for
  a square J, Cauchy-Binet with one redundant joint.
* :func:`structured_transversality`: g = H_F - (Jc_R^-1 Jc_F)^T H_R without the (m+h)
  symbolic solve, via the platform's null basis, at zero planar pose (x_a is invariant).
* :func:`structured_solve`: E^-1 B through ker A, an (n-h) solve instead of (n).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import NDArray

from mmplan.robot.dynamics import angular_jacobian
from mmplan.robot.robot import Robot
from mmplan.robot.tree import WORLD, JointKind


def _path_coordinates(robot: Robot, body: str) -> set[str]:
    """Coordinates of the joints on the path from the world to ``body``."""
    out = set()
    while body != WORLD:
        joint = robot.tree.parent_joint(body)
        if joint.coordinate is not None:
            out.add(joint.coordinate)
        body = joint.parent
    return out


def rigid_coordinates(robot: Robot) -> tuple[int, ...]:
    """Coordinates that move the end effector and every other arm joint as one rigid body.

    Such a joint (the planar pose, and the arm's root joint) maps every column of the arm
    Jacobian J_mu by the same rotation Q (a revolute column z x (p - o) with z, o fixed by the
    joint's own motion, prismatic columns and angular columns alike), so det(J_mu J_mu^T) and
    mu do not depend on it.
    """
    child = {j.coordinate: j.child for j in robot.tree.joints if j.coordinate is not None}
    ee_path = _path_coordinates(robot, robot.end_effector.body)
    arm = [robot.coordinates[i] for i in robot.arm_indices]
    return tuple(
        k
        for k, name in enumerate(robot.coordinates)
        if name in ee_path
        and all(name in _path_coordinates(robot, child[c]) for c in arm if c != name)
    )


def reduced_manipulability(robot: Robot, J: ca.SX | None = None) -> ca.SX:
    """mu(q) ([PajakPajak] eq. (5)) with the rigid coordinates set to 0, in a cheaper equal form.

    Equal to the robot's sqrt(det(J_mu J_mu^T)) up to rounding (:func:`rigid_coordinates`),
    with J_mu (k, n_a) taken at zero rigid coordinates and det(J_mu J_mu^T) = det(J_mu)^2
    when square, the sum of the squared k x k minors (Cauchy-Binet) with one redundant
    joint. Fewer operations to differentiate three times, and no loss of digits at small mu.
    ``J``: another point's Jacobian over the arm joints that move it (the wrist centre,
    :mod:`~mmplan.planners.extended_jacobian.wrist`); default the robot's J_mu.
    """
    s = robot.symbols
    zero = ca.SX(s.q)
    for k in rigid_coordinates(robot):
        zero[k] = 0
    if J is None:
        J = s.jacobian_arm
        if robot.end_effector.manipulability == "pose":
            J = ca.vertcat(J, angular_jacobian(s.ee_rotation, s.q)[:, list(robot.arm_indices)])
    J = ca.substitute(J, s.q, zero)
    k, n_a = J.shape
    if n_a == k:
        mu = ca.fabs(ca.det(J))
    elif n_a == k + 1:
        minors = [ca.det(J[:, [j for j in range(n_a) if j != i]]) for i in range(n_a)]
        mu = ca.sqrt(ca.sumsqr(ca.vertcat(*minors)))
    else:
        mu = ca.sqrt(ca.fmax(ca.det(J @ J.T), 0))
    return ca.cse(mu)  # merged before AD: the substitution duplicates sin/cos nodes


def _planar_pose(robot: Robot) -> bool:
    """The first three coordinates are the world x, y slides and heading of the platform."""
    if robot.n_platform < 3:
        return False
    kinds = (JointKind.PRISMATIC, JointKind.PRISMATIC, JointKind.REVOLUTE)
    axes = ((1, 0, 0), (0, 1, 0), (0, 0, 1))
    parent = WORLD
    for k in range(3):
        joint = next(j for j in robot.tree.joints if j.coordinate == robot.coordinates[k])
        if (joint.kind, tuple(joint.axis), joint.parent) != (kinds[k], axes[k], parent) or any(
            joint.origin_xyz + joint.origin_rpy
        ):
            return False
        parent = joint.child
    return parent == "platform"


def structured_transversality(
    robot: Robot, R: Sequence[int], F: Sequence[int], Hq: ca.SX
) -> ca.SX | None:
    r"""g of [PajakPajak] eq. (11) without the (m+h) solve, when R holds every platform coordinate.

    Then F is arm joints only and Jc_F = [J_F; 0]: the R rows of X = Jc_R^{-1} Jc_F solve
    A_p x_p = 0, J_p x_p + J_Ra x_a = J_F, i.e. x_p = N_p z with N_p the platform's null
    basis and [J_p N_p, J_Ra] [z; x_a] = J_F, an (m, m) system. With grad H zero on the
    platform (mu from :func:`reduced_manipulability`), g = H_F - x_a^T H_Ra. Everything is
    taken at zero platform pose (x_a is invariant under planar motion: all columns rotate
    together), and for m = 3, one arm joint in R, Cramer's rule gives
    x_a = c^T J_F / c^T J_Ra with c the cross product of the two columns of J_p N_p.

    Returns:
        g (n-m-h,), or None when the structure does not apply (use the reference).
    """
    s = robot.symbols
    q, n_p, h = s.q, robot.n_platform, robot.h
    R, F = list(R), list(F)
    flat = all(Hq[i].is_zero() for i in range(n_p))
    if not (flat and _planar_pose(robot) and set(range(n_p)) <= set(R)):
        return None
    Ra = [i for i in R if i >= n_p]
    if not Ra:
        return Hq[F]
    posed = ca.vertcat(ca.SX.zeros(3), q[3:])
    J = ca.cse(ca.substitute(s.jacobian, q, posed))
    N_p = ca.substitute(s.null_basis[:n_p, : n_p - h], q, posed)
    B = ca.horzcat(J[:, :n_p] @ N_p, J[:, Ra])
    if B.shape == (3, 3) and len(Ra) == 1:
        c = ca.cross(B[:, 0], B[:, 1])
        nz = [k for k in range(3) if not c[k].is_zero()]
        k = nz[0] if len(nz) == 1 else None  # c = c_k e_k: c_k cancels
        x_a = J[k, F] / J[k, Ra] if k is not None else (c.T @ J[:, F]) / (c.T @ J[:, Ra])
    else:
        x_a = ca.solve(B, J[:, F])[n_p - h :, :]
    return Hq[F] - x_a.T @ Hq[Ra]


def selected_transversality(
    robot: Robot, sigma: ca.SX, S_F: ca.SX, Hq: ca.SX
) -> tuple[ca.SX, tuple[int, ...]] | None:
    r""":func:`structured_transversality` with the partition as numbers: R = platform + the
    arm joint picked by the one-hot ``sigma`` (n_a,), F = the arm joints picked by the
    columns of ``S_F`` (n_a, n_a - 1) (:mod:`~mmplan.planners.extended_jacobian.parameters`).

    Same operations with J_Ra = J_arm sigma and J_F = J_arm S_F (products with 0 and 1: the
    same values to rounding). Returns g and the arm joints (robot indices) that may be
    picked (the others divide by a structural zero: Jc_R singular at every q, youbot-3r's
    q1), or None when the structure does not apply (m = 3, one arm joint in R, the
    platform's null basis of two columns: the youBots, TIAGo).
    """
    s = robot.symbols
    q, n_p, h = s.q, robot.n_platform, robot.h
    arm = list(robot.arm_indices)
    if not (all(Hq[i].is_zero() for i in range(n_p)) and _planar_pose(robot)):
        return None
    if len(arm) < 2 or n_p - h != 2 or arm != list(range(n_p, robot.n)):
        return None
    posed = ca.vertcat(ca.SX.zeros(3), q[3:])
    J = ca.cse(ca.substitute(s.jacobian, q, posed))
    if J.shape[0] != 3:
        return None
    N_p = ca.substitute(s.null_basis[:n_p, : n_p - h], q, posed)
    Jp = J[:, :n_p] @ N_p
    c = ca.cross(Jp[:, 0], Jp[:, 1])
    J_arm = J[:, arm]
    nz = [k for k in range(3) if not c[k].is_zero()]
    row = J_arm[nz[0], :] if len(nz) == 1 else c.T @ J_arm  # c = c_k e_k: c_k cancels
    x_a = (row @ S_F) / (row @ sigma)  # (1, n_a - 1)
    H_arm = Hq[arm]
    choices = tuple(i for j, i in enumerate(arm) if not row[j].is_zero())
    return S_F.T @ H_arm - x_a.T @ (sigma.T @ H_arm), choices


def selectable(robot: Robot, R: Sequence[int], choices: Sequence[int]) -> bool:
    """R = every platform coordinate + one of the arm joints ``choices``."""
    n_p = robot.n_platform
    extra = set(R) - set(range(n_p))
    return set(range(n_p)) <= set(R) and len(extra) == 1 and extra <= set(choices)


def partition_selection(n_platform: int, n_arm: int, partition: Any) -> NDArray[np.float64]:
    """[sigma; vec(S_F)] (n_arm^2,) of a partition (R, F) with R = platform + one arm joint:
    sigma the one-hot choice of that joint, S_F's columns the F joints in robot order
    (:func:`selected_transversality`).

    Raises:
        ValueError: the partition is not of that form.
    """
    n_p, n_a = n_platform, n_arm
    ra = [i - n_p for i in partition.R if i >= n_p]
    f = [i - n_p for i in partition.F]
    if len(ra) != 1 or len(f) != n_a - 1 or set(range(n_p)) - set(partition.R):
        raise ValueError(f"partition {partition} is not platform + one arm joint")
    sigma = np.zeros(n_a)
    sigma[ra[0]] = 1.0
    S_F = np.zeros((n_a, n_a - 1))
    S_F[f, range(n_a - 1)] = 1.0
    return np.concatenate([sigma, S_F.ravel(order="F")])


def structured_solve(robot: Robot, E: ca.SX, B: ca.SX) -> ca.SX:
    r"""X = E^{-1} B for E = [De; A] (n, n), A (h, n) the robot's Pfaffian ([PajakPajak] eq. (16)).

    Every solution of A x = b_A is x = N w + Y b_A with N the null basis (n, n-h) of A and
    Y = A^T (A A^T)^{-1} a right inverse, so E x = b reduces to the (n-h) system
    (De N) w = b_e - De Y b_A: a smaller symbolic solve (same values up to rounding).
    """
    n, h = robot.n, robot.h
    if h == 0:
        return ca.solve(E, B)
    De, A = E[: n - h, :], E[n - h :, :]
    N = robot.symbols.null_basis
    Y = A.T @ ca.solve(A @ A.T, ca.SX.eye(h))
    x_A = Y @ B[n - h :, :]
    w = ca.solve(De @ N, B[: n - h, :] - De @ x_A)
    return N @ w + x_A
