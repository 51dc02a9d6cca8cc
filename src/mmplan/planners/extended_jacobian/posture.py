r"""Criterion terms for real robots: arm posture and platform heading (our additions).

[PajakPajak] eq. (9) and [Pajak] eq. (8) leave the criterion H = -mu + sum kappa_i open
beyond "manipulability plus joint-limit penalties". Two terms make it usable on arms and
platforms the papers did not treat (docs/extended_jacobian.md, Real robots); robots like
the papers' youBots get neither, so their plans are unchanged.

* :func:`posture_term`, sum_i (beta_i/2) (q_i - c_i)^2 over the arm joints (c_i the centre
  of the joint's range): on every arm joint of an arm with more than m + 1 = 4 positioning
  joints, and on the wrist joints (:func:`posture_weights`).
* :func:`heading_term` for a platform whose heading no other term determines: an
  omnidirectional base (h = 0) can turn about the vertical through the end effector while
  x and y follow, which leaves every arm joint, hence mu and the penalties, unchanged. g
  then has an identically zero row and E is singular at every state (measured on ur5-omni:
  cond(E(q0)) = 1.1e17).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from mmplan.arrays import Array
from mmplan.planners.extended_jacobian.wrist import find_wrist, positioning_joints
from mmplan.robot.robot import Robot

#: Posture weight beta [1/rad^2, 1/m^2 for prismatic joints] for redundant positioning chains.
POSTURE_WEIGHT = 1.0
#: Heading weight of :func:`heading_term` (its curvature at theta_ref) [1/rad^2].
HEADING_WEIGHT = 1.0


def posture_term(q_arm: ca.SX, q_min: Array, q_max: Array, weights: Array) -> ca.SX:
    r"""sum_i (beta_i/2) (q_i - c_i)^2 over the arm joints with a finite range and beta_i > 0,
    c_i the centre of the range.

    It makes the criterion convex along the self-motion where -mu alone is not
    (:func:`posture_weights`).
    """
    terms = [
        0.5 * weights[i] * (q_arm[i] - 0.5 * (q_min[i] + q_max[i])) ** 2
        for i in range(q_arm.numel())
        if weights[i] > 0.0 and np.isfinite(q_min[i]) and np.isfinite(q_max[i])
    ]
    return ca.sum1(ca.vertcat(*terms)) if terms else ca.SX(0)


def posture_weights(robot: Robot, weight: float | None = None) -> Array:
    r"""beta_i of :func:`posture_term` per arm joint (n_arm,).

    A given ``weight`` (setting ``posture_weight``) applies to every arm joint. Without one:
    :data:`POSTURE_WEIGHT` on every arm joint when more than m + 1 = 4 arm joints position
    the manipulability point (TIAGo: torso and arm_1..4), else on the wrist joints only
    (:mod:`~mmplan.planners.extended_jacobian.wrist`; ur5-omni: wrist_2, wrist_3), and 0 on
    every joint of an arm without a wrist and with at most 4 joints (youbot-3r, youbot-4r:
    the papers' criterion, unchanged).

    Measured on TIAGo (five positioning joints, a 7-dimensional self-motion with the
    platform): with beta = 0 the reduced Hessian of H = -mu + penalty on the self-motion is
    indefinite (eigenvalues -0.03 ... 2.8 at a mid-range start) and the generator, which
    solves g = 0 like a Newton flow, either crossed a fold where E lost rank (diverged
    between 0.13 and 1.3 s on 10 of 10 goals around the robot) or converged to a saddle
    (one eigenvalue -0.42, final mu 0.174 below the start's 0.224). With beta = 1 rad^-2
    (above the curvature of mu there, |.| <= 0.45) every eigenvalue at the end lies in
    0.89 ... 8.2 and 32 of 32 goals from two starts were reached. Wrist joints lie outside
    mu; their only curvature is the joint-limit penalty's, 4 w / d^3 at mid-range (TIAGo
    arm_5..7: 0.002-0.007; UR5 wrists, range +-2 pi: 0.0002), which the coupling through
    the end effector's lever outweighs (ur5-omni: wrist_2 ran away at t = 1.6 s, NaN at
    1.76 s, on 2 of 10 goals).
    """
    n_arm = len(robot.arm_indices)
    if weight is not None:
        return np.full(n_arm, float(weight))
    out = np.zeros(n_arm)
    if positioning_joints(robot) > 4:
        out[:] = POSTURE_WEIGHT
    wrist = find_wrist(robot)
    if wrist is not None:
        for i in wrist.joints:
            out[i - robot.n_platform] = POSTURE_WEIGHT
    return out


def heading_symmetric(robot: Robot) -> bool:
    """True when the planar pose can turn about the end effector with every arm joint held:
    three free platform coordinates (x, y, theta) and no Pfaffian constraint."""
    return robot.h == 0 and robot.n_platform >= 3


def heading_reference(robot: Robot, q0: Array, p_f: Array) -> float | None:
    """theta_ref of :func:`heading_term` for a heading-symmetric robot, else None: the
    direction from the start's platform position to the goal (the start heading when the
    goal lies within 0.1 m of it horizontally)."""
    if not heading_symmetric(robot):
        return None
    d = np.asarray(p_f[:2], dtype=float) - np.asarray(q0[:2], dtype=float)
    if float(np.linalg.norm(d)) < 0.1:
        return float(q0[2])
    return float(np.arctan2(d[1], d[0]))


def heading_term(
    q: ca.SX, theta_ref: float | ca.SX, weight: float = HEADING_WEIGHT
) -> ca.SX:
    r"""weight (1 - cos(theta - theta_ref)): the platform faces theta_ref
    (:func:`heading_reference`), smooth and periodic.

    A reference fixed in the world is needed: a term in the direction from the platform to
    the goal is itself invariant under turning the whole robot about the goal, so it leaves
    E singular once the end effector arrives (measured on ur5-omni: the smallest eigenvalue
    of dg/dq on the self-motion fell from 0.64 to 0.05 as the error fell from 1.76 to
    0.96 m, and the run diverged at t = 1.22 s).
    """
    return weight * (1.0 - ca.cos(q[2] - theta_ref))
