r"""Rigid-body dynamics of a kinematic tree by Lagrange's equations (symbolic, CasADi).

For generalized coordinates q (n,) the unconstrained equations of motion are

.. math::

    M(q)\,\ddot q + c(q, \dot q) = Q, \qquad
    M = \sum_b m_b J_{v,b}^T J_{v,b} + J_{\omega,b}^T R_b I_b R_b^T J_{\omega,b},

    c = \dot M \dot q - \tfrac12 \partial_q(\dot q^T M \dot q) + \partial_q V + f(\dot q),

with J_{v,b} = d p_{com,b}/dq (3, n), J_{\omega,b} the angular-velocity Jacobian
(columns vee(dR_b/dq_i R_b^T)), V the gravity potential and f optional joint friction.
This is [PajakPajak] eq. (2) without the constraint term A^T lambda, which the
planners add. The result is checked against Pinocchio's CRBA/RNEA in the tests.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import casadi as ca
import numpy as np

from mmplan.robot.tree import KinematicTree

GRAVITY = 9.81


@dataclass(frozen=True)
class Friction:
    """Joint friction on one coordinate: viscous [N m s/rad] and smoothed Coulomb [N m].

    Coulomb friction is smoothed as ``coulomb * tanh(dq / smoothing)`` so that the bias
    term stays differentiable.
    """

    viscous: float = 0.0
    coulomb: float = 0.0
    smoothing: float = 1e-2


def angular_jacobian(R: ca.SX, q: ca.SX) -> ca.SX:
    """Angular-velocity Jacobian (3, n) of a rotation matrix R(q): omega = Jw dq."""
    n = q.shape[0]
    dR = ca.jacobian(ca.vec(R), q)  # (9, n), column-major vec
    cols = []
    for i in range(n):
        dRi = ca.reshape(dR[:, i], 3, 3)
        W = dRi @ R.T  # skew-symmetric
        cols.append(ca.vertcat(W[2, 1], W[0, 2], W[1, 0]))
    return ca.horzcat(*cols)


def mass_matrix(tree: KinematicTree, q: ca.SX, transforms: Mapping[str, ca.SX]) -> ca.SX:
    """Joint-space inertia matrix M(q) (n, n), symmetric positive (semi)definite."""
    n = q.shape[0]
    M = ca.SX.zeros(n, n)
    coms = tree.com_positions(transforms)
    for name, p_com in coms.items():
        inertial = tree.bodies[name].inertial
        Jv = ca.jacobian(p_com, q)
        M += inertial.mass * (Jv.T @ Jv)
        I_body = inertial.inertia_matrix
        if np.any(I_body != 0.0):
            R = transforms[name][:3, :3]
            Jw = angular_jacobian(R, q)
            M += Jw.T @ (R @ ca.DM(I_body) @ R.T) @ Jw
    return M


def potential_energy(tree: KinematicTree, transforms: Mapping[str, ca.SX]) -> ca.SX:
    """Gravity potential V(q) = sum_b m_b g z_com,b [J] (gravity along -z)."""
    V = ca.SX(0)
    for name, p_com in tree.com_positions(transforms).items():
        V += tree.bodies[name].inertial.mass * GRAVITY * p_com[2]
    return V


def bias_forces(
    M: ca.SX,
    V: ca.SX,
    q: ca.SX,
    dq: ca.SX,
    friction: Mapping[int, Friction] | None = None,
) -> ca.SX:
    """c(q, dq) (n,): Coriolis, centrifugal, gravity and optional friction generalized forces."""
    Mdq = M @ dq
    c = ca.jacobian(Mdq, q) @ dq - 0.5 * ca.gradient(ca.dot(dq, Mdq), q) + ca.gradient(V, q)
    for index, f in (friction or {}).items():
        c[index] += f.viscous * dq[index] + f.coulomb * ca.tanh(dq[index] / f.smoothing)
    return c
