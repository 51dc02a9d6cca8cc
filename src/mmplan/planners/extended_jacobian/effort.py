"""Effort split of the extended-Jacobian generator: tau = T0 + Tm ddq ([PajakPajak] eq. (22)).

tau = (N^T B)^-1 N^T (M ddq + c) ([PajakPajak] eqs. (21)-(22), [Pajak] eqs. (14)-(15)) is affine in
ddq; the generator needs T0 (with the velocity terms) and Tm at every sample, so their expressions
are kept small (see :func:`effort_split`).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from mmplan.robot.robot import Robot


def effort_split(robot: Robot) -> tuple[ca.SX, ca.SX]:
    """T0 (n_act,) and Tm (n_act, n) with tau = T0 + Tm ddq ([PajakPajak] eq. (22)).

    Without friction c(q, dq) = C(q, dq) dq + g(q) is rebuilt by Lagrange's equations from
    the kinetic energy T written with the bodies' velocities (sum m |v_c|^2 / 2 +
    omega^T I omega / 2): c = d/dt(dT/d dq) - dT/dq + g(q), 2.5-3x smaller than the robot's
    bias (equal to 1e-17, tests/planners/extended_jacobian/test_effort.py); with friction the
    robot's bias is used as is.
    """
    s = robot.symbols
    q, dq = s.q, s.dq
    NB = s.null_basis.T @ s.actuation  # (n_act, n_act)
    if robot.friction:
        bias = s.bias
    else:
        gravity = ca.substitute(s.bias, dq, ca.SX.zeros(robot.n))
        ke = ca.SX(0)  # kinetic energy from body velocities (cheaper than dq^T M dq / 2)
        for name, pc in robot.tree.com_positions(s.transforms).items():
            body = robot.tree.bodies[name].inertial
            ke += 0.5 * body.mass * ca.sumsqr(ca.jtimes(pc, q, dq))
            if np.any(body.inertia_matrix != 0):
                R = s.transforms[name][:3, :3]
                W = ca.jtimes(R, q, dq) @ R.T  # [omega]x in the world frame
                w = R.T @ ca.vertcat(W[2, 1], W[0, 2], W[1, 0])
                ke += 0.5 * w.T @ ca.DM(body.inertia_matrix) @ w
        ke = ca.cse(ke)
        bias = ca.jtimes(ca.gradient(ke, dq), q, dq) - ca.gradient(ke, q) + gravity
    T0 = ca.solve(NB, s.null_basis.T @ bias)
    Tm = ca.solve(NB, s.null_basis.T @ s.mass_matrix)
    return T0, Tm
