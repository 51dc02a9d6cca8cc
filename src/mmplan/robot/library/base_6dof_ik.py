r"""Vectorized kinematics of the scaled PUMA 560 arm of base-6dof ([Nagatani]).

The arm is defined in docs/conventions.md. All functions work on batches: joint arrays are (N, 6),
poses are given in the *arm frame* (origin at the shoulder, z vertical, x along the platform
heading), so one call covers a whole grid of candidate base positions without a Python loop over
cells.

Standard DH (Corke's PUMA 560, scaled by 0.4): link i is
:math:`T_i = R_z(q_i) T_z(d_i) T_x(a_i) R_x(\alpha_i)`, with d = (0, 0, d3, d4, 0, 0),
a = (0, a2, a3, 0, 0, 0), alpha = (pi/2, 0, -pi/2, pi/2, -pi/2, 0). The tool tip is
``tool`` metres along the flange z axis.

Inverse kinematics (closed form, the branch labels of Corke's ``ikine_a``/Paul and Zhang
(1986); the default is docs/conventions.md's "shoulder +, elbow up, no flip" = Corke's "run"):

* wrist centre :math:`p_w = p - t\,z_6`; with :math:`r = a_2 c_2 + a_3 c_{23} - d_4 s_{23}`
  and :math:`z = a_2 s_2 + a_3 s_{23} + d_4 c_{23}`, the FK gives
  :math:`p_w = (c_1 r + d_3 s_1,\; s_1 r - d_3 c_1,\; z)`;
* shoulder :math:`\sigma_s = \pm 1`: :math:`r = \sigma_s \sqrt{p_x^2 + p_y^2 - d_3^2}`
  (+: wrist centre in front of axis 1, Corke's right-handed "r"),
  :math:`q_1 = \mathrm{atan2}(p_y, p_x) - \mathrm{atan2}(-d_3, r)`;
* elbow :math:`\sigma_e = \pm 1` (+: Corke's "u"): :math:`q_2 = \mathrm{atan2}(z, r) -
  \sigma_e \sigma_s \beta` with :math:`\cos\beta = (a_2^2 + D^2 - L^2) / (2 a_2 D)`,
  :math:`D^2 = r^2 + z^2`, :math:`L^2 = a_3^2 + d_4^2`; then :math:`q_2 + q_3 =
  \mathrm{atan2}(z - a_2 s_2, r - a_2 c_2) - \mathrm{atan2}(d_4, a_3)`. Note: with this DH
  convention Corke's "u" (shoulder +) puts the elbow *below* the shoulder-wrist line in the
  (r, z) plane; it is the branch that reproduces the reference runs' numbers [RefRuns]
  (w min 0.00398 on its reference path; the other elbow gives 0.00249 there);
* wrist not flipped (Corke's "n", ZYZ Euler angles with :math:`s_5 \le 0`): with
  :math:`a = R_{03}^T z_6 = (-c_4 s_5, -s_4 s_5, c_5)`,
  :math:`q_5 = -\mathrm{atan2}(\sqrt{a_x^2 + a_y^2}, a_z)`, :math:`q_4 = \mathrm{atan2}(a_y,
  a_x)`; flipped: :math:`q_4 + \pi, -q_5`; :math:`q_6` from the flange x axis in frame 5.

Manipulability (Yoshikawa, [Nagatani] eq. (1)) of the 6x6 Jacobian of the tool tip (linear
velocity [m/s] and angular velocity [rad/s] per joint rate): :math:`w = |\det J|`, in
closed form :math:`w = a_2 |s_5|\,|d_4 c_3 + a_3 s_3|\,|r|` (independent of q1, q4, q6 and
of the tool length).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mmplan.arrays import Array, BoolArray
from mmplan.errors import ModelError
from mmplan.robot.library import base_6dof

_PUMA_ALPHA = (np.pi / 2, 0.0, -np.pi / 2, np.pi / 2, -np.pi / 2, 0.0)


@dataclass(frozen=True)
class PumaGeometry:
    """DH geometry of a PUMA-type arm (zero d1, d2, d5, d6, a1, a4, a5, a6).

    Attributes:
        d, a, alpha: Standard DH parameters (6,) [m, m, rad].
        tool: Tool tip offset along the flange z axis [m].
        shoulder_height: Height of the arm frame above the platform frame [m].
    """

    d: tuple[float, ...]
    a: tuple[float, ...]
    alpha: tuple[float, ...]
    tool: float
    shoulder_height: float

    def __post_init__(self) -> None:
        zero = (
            self.d[0],
            self.d[1],
            self.d[4],
            self.d[5],
            self.a[0],
            self.a[3],
            self.a[4],
            self.a[5],
        )
        if len(self.d) != 6 or len(self.a) != 6 or len(self.alpha) != 6:
            raise ModelError("PumaGeometry: expected 6 DH rows")
        if any(abs(v) > 1e-12 for v in zero) or not np.allclose(self.alpha, _PUMA_ALPHA):
            raise ModelError(
                "PumaGeometry: not a PUMA 560 structure; the closed-form IK needs "
                f"alpha={_PUMA_ALPHA} and only d3, d4, a2, a3 non-zero"
            )

    @classmethod
    def base_6dof(cls) -> PumaGeometry:
        """Geometry of the built-in robot ``base-6dof``."""
        rows = base_6dof.dh_scaled()
        return cls(
            tuple(r[0] for r in rows),
            tuple(r[1] for r in rows),
            tuple(r[2] for r in rows),
            base_6dof.TOOL,
            base_6dof.SHOULDER_HEIGHT,
        )


@dataclass(frozen=True)
class IKSolution:
    """Batch IK result: joints (N, 6) (zeros where unreachable) and the reachable mask (N,)."""

    q: Array
    reachable: BoolArray


def dh_frames(geom: PumaGeometry, q: Array) -> Array:
    """Frames T_0_i of the arm, i = 0..6, (N, 7, 4, 4); T_0_0 = I (arm frame)."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    N = q.shape[0]
    out = np.empty((N, 7, 4, 4))
    out[:, 0] = np.eye(4)
    for i in range(6):
        c, s = np.cos(q[:, i]), np.sin(q[:, i])
        ca, sa = np.cos(geom.alpha[i]), np.sin(geom.alpha[i])
        T = np.zeros((N, 4, 4))
        T[:, 0, 0], T[:, 0, 1], T[:, 0, 2], T[:, 0, 3] = c, -s * ca, s * sa, geom.a[i] * c
        T[:, 1, 0], T[:, 1, 1], T[:, 1, 2], T[:, 1, 3] = s, c * ca, -c * sa, geom.a[i] * s
        T[:, 2, 1], T[:, 2, 2], T[:, 2, 3] = sa, ca, geom.d[i]
        T[:, 3, 3] = 1.0
        out[:, i + 1] = out[:, i] @ T
    return out


def tool_pose(geom: PumaGeometry, q: Array) -> tuple[Array, Array]:
    """Tool tip position (N, 3) and flange rotation (N, 3, 3) in the arm frame."""
    T = dh_frames(geom, q)[:, 6]
    return T[:, :3, 3] + geom.tool * T[:, :3, 2], T[:, :3, :3]


def _wrap(angle: Array) -> Array:
    return np.asarray((angle + np.pi) % (2 * np.pi) - np.pi)


def _wrist_reach(
    geom: PumaGeometry, p: Array, z_tool: Array, shoulder: int
) -> tuple[Array, Array, Array, BoolArray]:
    """Wrist centre (N, 3), signed reach r (N,), cos(beta) (N,) and the reachable mask (N,)."""
    a2, a3, d3, d4 = geom.a[1], geom.a[2], geom.d[2], geom.d[3]
    pw = p - geom.tool * z_tool
    rho2 = pw[:, 0] ** 2 + pw[:, 1] ** 2 - d3**2
    r = shoulder * np.sqrt(np.maximum(rho2, 0.0))
    D = np.hypot(r, pw[:, 2])
    with np.errstate(divide="ignore", invalid="ignore"):
        cos_beta = (a2**2 + D**2 - a3**2 - d4**2) / (2.0 * a2 * D)
    reachable = (rho2 >= 0.0) & (D > 0.0) & (np.abs(cos_beta) <= 1.0)
    return pw, r, cos_beta, reachable


def _first_three(
    geom: PumaGeometry, pw: Array, r: Array, cos_beta: Array, shoulder: int, elbow: int
) -> tuple[Array, Array, Array, Array]:
    """q1, q2, q3 and q2 + q3 (each (n,)) of reachable wrist centres (module docstring)."""
    a2, a3, d3, d4 = geom.a[1], geom.a[2], geom.d[2], geom.d[3]
    z = pw[:, 2]
    q1 = np.arctan2(pw[:, 1], pw[:, 0]) - np.arctan2(-d3, r)
    q2 = np.arctan2(z, r) - elbow * shoulder * np.arccos(np.clip(cos_beta, -1.0, 1.0))
    q23 = np.arctan2(z - a2 * np.sin(q2), r - a2 * np.cos(q2)) - np.arctan2(d4, a3)
    return q1, q2, q23 - q2, q23


def _in_frame3(q1: Array, q23: Array, v: Array) -> Array:
    """Arm-frame vectors v (n, 3) in frame 3, whose axes are x3 = (c1 c23, s1 c23, s23),
    y3 = (-s1, c1, 0), z3 = (-c1 s23, -s1 s23, c23); (n, 3)."""
    c1, s1, c23, s23 = np.cos(q1), np.sin(q1), np.cos(q23), np.sin(q23)
    return np.stack(
        [
            c1 * c23 * v[:, 0] + s1 * c23 * v[:, 1] + s23 * v[:, 2],
            -s1 * v[:, 0] + c1 * v[:, 1],
            -c1 * s23 * v[:, 0] - s1 * s23 * v[:, 1] + c23 * v[:, 2],
        ],
        axis=1,
    )


def _batch(position: Array, rotation: Array) -> tuple[Array, Array]:
    p = np.atleast_2d(np.asarray(position, dtype=float))
    return p, np.broadcast_to(np.asarray(rotation, dtype=float), (p.shape[0], 3, 3))


def inverse(
    geom: PumaGeometry,
    position: Array,
    rotation: Array,
    shoulder: int = 1,
    elbow: int = 1,
    flip: bool = False,
) -> IKSolution:
    """Closed-form IK of one branch (module docstring); default shoulder +, elbow up, no flip.

    Args:
        geom: Arm geometry.
        position: Tool tip positions in the arm frame, (N, 3) [m].
        rotation: Flange rotations in the arm frame, (3, 3) shared or (N, 3, 3).
        shoulder: +1 (wrist centre in front of axis 1) or -1.
        elbow: +1 (Corke's "u") or -1 ("d").
        flip: Wrist flipped (Corke's "f").

    Returns:
        Joints wrapped to (-pi, pi], (N, 6) (zeros where unreachable), the reachable mask (N,).
    """
    p, R = _batch(position, rotation)
    pw, r, cos_beta, reachable = _wrist_reach(geom, p, R[:, :, 2], shoulder)
    idx = np.flatnonzero(reachable)
    q = np.zeros((p.shape[0], 6))
    if idx.size == 0:
        return IKSolution(q, reachable)
    q1, q2, q3, q23 = _first_three(geom, pw[idx], r[idx], cos_beta[idx], shoulder, elbow)
    a = _in_frame3(q1, q23, R[idx, :, 2])  # tool axis z6 = (-c4 s5, -s4 s5, c5) in frame 3
    b = _in_frame3(q1, q23, R[idx, :, 0])  # flange x axis in frame 3
    sgn = 1.0 if flip else -1.0
    q5 = sgn * np.arctan2(np.hypot(a[:, 0], a[:, 1]), a[:, 2])
    q4 = np.arctan2(-sgn * a[:, 1], -sgn * a[:, 0])
    # the wrist is R_34 R_45 = R_z(q4) R_y(-q5): x5 = (c4 c5, s4 c5, s5), y5 = (-s4, c4, 0)
    c4, s4, c5, s5 = np.cos(q4), np.sin(q4), np.cos(q5), np.sin(q5)
    q6 = np.arctan2(
        -s4 * b[:, 0] + c4 * b[:, 1], c4 * c5 * b[:, 0] + s4 * c5 * b[:, 1] + s5 * b[:, 2]
    )
    q[idx] = _wrap(np.column_stack([q1, q2, q3, q4, q5, q6]))
    return IKSolution(q, reachable)


def pose_manipulability(
    geom: PumaGeometry, position: Array, rotation: Array, shoulder: int = 1, elbow: int = 1
) -> tuple[Array, BoolArray]:
    """w of the IK solution without the wrist angles (w needs q2, q3 and |s5| only), (N,), and
    the reachable mask (N,); w = 0 where unreachable. Same result as
    ``manipulability(inverse(...).q)`` (either wrist branch), for the grid's hot loop."""
    p, R = _batch(position, rotation)
    pw, r, cos_beta, reachable = _wrist_reach(geom, p, R[:, :, 2], shoulder)
    idx = np.flatnonzero(reachable)
    w = np.zeros(p.shape[0])
    if idx.size:
        q1, _, q3, q23 = _first_three(geom, pw[idx], r[idx], cos_beta[idx], shoulder, elbow)
        a = _in_frame3(q1, q23, R[idx, :, 2])
        a2, a3, d4 = geom.a[1], geom.a[2], geom.d[3]
        elbow_factor = d4 * np.cos(q3) + a3 * np.sin(q3)
        w[idx] = a2 * np.hypot(a[:, 0], a[:, 1]) * np.abs(elbow_factor) * np.abs(r[idx])
    return w, reachable


def jacobian(geom: PumaGeometry, q: Array) -> Array:
    """Geometric Jacobian of the tool tip in the arm frame, (N, 6, 6).

    Column i: :math:`(z_{i-1} \\times (p - o_{i-1}),\\; z_{i-1})`, rows (v [m/s], omega
    [rad/s]).
    """
    F = dh_frames(geom, q)
    p = F[:, 6, :3, 3] + geom.tool * F[:, 6, :3, 2]
    z = F[:, :6, :3, 2]  # (N, 6, 3)
    o = F[:, :6, :3, 3]
    Jv = np.cross(z, p[:, None, :] - o)
    return np.concatenate([Jv, z], axis=2).transpose(0, 2, 1)


def manipulability(geom: PumaGeometry, q: Array) -> Array:
    """Closed-form :math:`w = \\sqrt{\\det(J J^T)} = a_2 |s_5| |d_4 c_3 + a_3 s_3| |r|`, (N,).

    Implements [Nagatani] eq. (1) for the PUMA structure (see the module docstring).
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    a2, a3, d4 = geom.a[1], geom.a[2], geom.d[3]
    q2, q3 = q[:, 1], q[:, 2]
    r = a2 * np.cos(q2) + a3 * np.cos(q2 + q3) - d4 * np.sin(q2 + q3)
    elbow = d4 * np.cos(q3) + a3 * np.sin(q3)
    return np.asarray(a2 * np.abs(np.sin(q[:, 4])) * np.abs(elbow) * np.abs(r))


def joint_rates(geom: PumaGeometry, q: Array, velocity: Array,
                acceleration: Array | None = None) -> tuple[Array, Array]:
    r"""Joint rates and accelerations that move the tool tip at ``velocity`` (N, 3) with
    ``acceleration`` (N, 3) (arm frame; zero when None) at a constant orientation:
    :math:`J \dot q = (v, 0)`, :math:`\ddot q = J^{-1} ((a, 0) - \dot J \dot q)`
    (:math:`\dot J \dot q` by central differences of J along :math:`\dot q`, step 1e-6).
    Returns (dq, ddq), each (N, 6); J must be regular (w > 0)."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    zeros = np.zeros((len(q), 3))
    rhs = np.concatenate([np.asarray(velocity, dtype=float), zeros], axis=1)
    acc = np.concatenate([zeros if acceleration is None else acceleration, zeros], axis=1)
    J = jacobian(geom, q)
    dq = np.linalg.solve(J, rhs[:, :, None])[:, :, 0]
    eps = 1e-6
    dJ = (jacobian(geom, q + eps * dq) - jacobian(geom, q - eps * dq)) / (2 * eps)
    ddq = np.linalg.solve(J, (acc - np.einsum("nij,nj->ni", dJ, dq))[:, :, None])[:, :, 0]
    return dq, ddq


def base_to_arm(
    geom: PumaGeometry, base_xy: Array, heading: float, position: Array, rotation: Array
) -> tuple[Array, Array]:
    """Express a world tool pose in the arm frame of bases at ``base_xy`` (N, 2), yaw ``heading``.

    Returns:
        Tool tip positions (N, 3) and the flange rotation (3, 3) in the arm frame.
    """
    c, s = np.cos(heading), np.sin(heading)
    Rz_T = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    xy = np.atleast_2d(np.asarray(base_xy, dtype=float))
    shoulder = np.column_stack([xy, np.full(len(xy), geom.shoulder_height)])
    rel = np.asarray(position, dtype=float)[None, :] - shoulder
    return rel @ Rz_T.T, Rz_T @ np.asarray(rotation, dtype=float)
