r"""Shaping of the obstacle push of [PajakPajak] eq. (19) (measured failures on random scenes).

Two fixes, both applied to the symbolic push in :mod:`~mmplan.planners.extended_jacobian.generator`:
near the goal its end-effector component fades out (:func:`project_push`, :func:`fade`); arm
components that drive a joint into its limit fade out (:func:`fade_at_limits`).

[PajakPajak] eq. (19) adds the push ddq_p in the null space of A only, so it also moves the end
effector. Near the goal, with part of the body inside an obstacle's neighbourhood (delta) but
far from contact, the push and the attraction of eq. (16) balance short of the goal (measured
on the random youbot-3r set: stalls 0.009-0.18 m from the goal, 0.29 m from the obstacle).

Here the push keeps its self-motion part (the body is still pushed away while the end effector
stays) and loses a fraction sigma of its task part:

.. math::
    f_p' = f_p - \sigma\, W^{-1} J_c^T (J_c W^{-1} J_c^T)^{-1} [J f_p; 0],
    \qquad J_c = [J; A],

so that J f_p' = (1 - sigma) J f_p and A f_p' = 0 (still in ker A, wheel metric W as the
projector of :mod:`~mmplan.planners.extended_jacobian.generator`). sigma = near(|k - p_f|) safe(K):
near is 1 within ``r_in`` of the goal and fades to 0 at ``r_out``; safe is 1 for K <= ``K_LO`` and
fades to 0 at ``K_HI`` (smoothsteps), so the full push returns when a point comes deep into a
neighbourhood (kappa = ((delta - C)/C)^2 is 1 at C = delta / 2, 4 at C = delta / 3). sigma must be
exactly 1 near the goal: any task part left balances the attraction at |e| ~ |J f_p| / Lambda_P
(measured 0.016 m with safe = exp(-K), K = 0.06).
"""

from __future__ import annotations

from collections.abc import Callable

import casadi as ca
import numpy as np
from numpy.typing import NDArray

from mmplan.planners.extended_jacobian.obstacles import conditional
from mmplan.robot.robot import Robot

#: Full projection within this end-effector error [m]; none beyond ``R_OUT``.
R_IN, R_OUT = 0.15, 0.3
#: Full projection while K <= K_LO; none from K_HI on.
K_LO, K_HI = 1.0, 4.0


def smoothstep(x: ca.SX) -> ca.SX:
    """3 x^2 - 2 x^3 on [0, 1], clamped outside."""
    c = ca.fmin(ca.fmax(x, 0.0), 1.0)
    return c * c * (3.0 - 2.0 * c)


def fade(err: ca.SX, K: ca.SX, r_in: float = R_IN, r_out: float = R_OUT) -> ca.SX:
    """sigma = near(err) safe(K) in [0, 1] (module docstring)."""
    near = smoothstep((r_out - err) / (r_out - r_in))
    return near * smoothstep((K_HI - K) / (K_HI - K_LO))


def project_push(
    fp: ca.SX,
    J: ca.SX,
    A: ca.SX,
    winv: NDArray[np.float64],
    sigma: ca.SX,
) -> ca.SX:
    """f_p' = f_p - sigma W^-1 Jc^T (Jc W^-1 Jc^T)^-1 [J f_p; 0] (module docstring).

    Args:
        fp: Push already in ker A (n,). J: Task Jacobian (3, n). A: Pfaffian (h, n).
        winv: Diagonal of W^-1 (n,). sigma: Fraction of the task part removed (scalar).
    """
    Jc = ca.vertcat(J, A)
    Winv = ca.diag(ca.DM(winv))
    M = Jc @ Winv @ Jc.T + 1e-12 * ca.SX.eye(Jc.shape[0])
    rhs = ca.vertcat(J @ fp, ca.SX.zeros(A.shape[0]))
    correction = Winv @ Jc.T @ ca.solve(M, rhs)
    # if_else: far from the goal (sigma = 0) the solve is not used (a singular M gives 0).
    return fp - ca.if_else(sigma > 0.0, sigma * correction, ca.SX.zeros(fp.shape[0]))


def fade_at_limits(
    fp: ca.SX,
    q: ca.SX,
    arm: list[int],
    q_min: NDArray[np.float64],
    q_max: NDArray[np.float64],
    margin: float = 0.2,
) -> ca.SX:
    """Arm components of the push that drive a joint towards its limit fade out within
    ``margin`` [rad] of it (smoothstep of the remaining distance).

    Measured on the random youbot-3r sets: a robot blocked by an obstacle had q2 pushed to
    0.005 rad from its limit, where the curvature of the joint-limit penalty (criterion H)
    made cond(E) > 1e8 (diverged). The arm columns of A are zero, so fp stays in ker A.
    The fade spans ``margin`` or 0.3 of the joint's range, whichever is smaller (the same
    for the youBots' ranges of 2.7-5.9 rad): TIAGo's torso, a prismatic joint with a range of
    0.35 m, lay always within 0.2 (m) of a limit, so its push was always partly cut after the
    near-goal projection (:func:`project_push`) and the push kept a task part: runs held
    0.7-3.6 mm from the goal under an obstacle's damping (measured on the random TIAGo set).
    """
    out = [fp[i] for i in range(fp.shape[0])]
    for j, i in enumerate(arm):
        room = ca.if_else(fp[i] > 0.0, q_max[j] - q[i], q[i] - q_min[j])
        out[i] = fp[i] * smoothstep(room / min(margin, RANGE_FRACTION * (q_max[j] - q_min[j])))
    return ca.vertcat(*out)


#: The fade of :func:`fade_at_limits` spans at most this fraction of a joint's range.
RANGE_FRACTION = 0.3


def finish_function(
    robot: Robot, A: ca.SX, q: ca.SX, p: ca.SX, winv: NDArray[np.float64]
) -> Callable[[ca.MX, ca.MX, ca.MX, ca.MX], ca.MX]:
    """The push as applied (:func:`project_push`, then :func:`fade_at_limits`) for the culled
    compiled step (:mod:`~mmplan.planners.extended_jacobian.obstacles`), as MX calls: the projection
    (a 6x6 solve) runs only where its fade is positive (within ``R_OUT`` of the goal), the
    joint-limit fade always.

    Args:
        robot: The robot. A: Its Pfaffian (h, n) in q. q: Coordinates symbol.
        p: Generator parameters symbol [p_f, gains]. winv: Diagonal of W^-1 (n,).
    """
    s = robot.symbols
    n = robot.n
    K_s, sigma_s, fp_s = ca.SX.sym("K"), ca.SX.sym("sigma"), ca.SX.sym("fp", n)
    err = ca.norm_2(s.ee_position - p[:3])
    fade_fn = ca.Function("mmplan_push_fade", [q, p, K_s], [fade(err, K_s)])
    project = ca.Function(
        "mmplan_push_project",
        [q, fp_s, sigma_s],
        ca.cse([project_push(fp_s, s.jacobian, A, winv, sigma_s)]),
    )
    limits = ca.Function(
        "mmplan_push_limits",
        [q, fp_s],
        [
            fade_at_limits(
                fp_s, q, list(robot.arm_indices), robot.limits.joint_min, robot.limits.joint_max
            )
        ],
    )

    keep = ca.Function("mmplan_push_keep", [q, fp_s, sigma_s], [fp_s])

    def finish(qm: ca.MX, pm: ca.MX, fp_raw: ca.MX, K: ca.MX) -> ca.MX:
        sigma = fade_fn(qm, pm, K)
        args = [qm, fp_raw, sigma]
        projected = conditional("mmplan_push_project_if", sigma > 0, project, args, keep)
        return limits(qm, projected)

    return finish
