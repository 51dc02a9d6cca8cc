r"""Path tracking by the weighted pseudoinverse ([AbdessemedDjebrani] s.2).

Implements [AbdessemedDjebrani] eqs. (18)-(32); our readings are in docs/tracking.md.
The stacked kinematics :math:`J(q)\,\dot q = [0;\ \dot X]` with :math:`J = [A(q);\ J_m(q)]`
((h + 3) x n: the Pfaffian rows of the platform, then the end-effector Jacobian) are solved for
the weighted minimum-norm velocity with drift correction and a null-space term (eq. (24)):

.. math::
    \dot q = W^{-1} J^T (J W^{-1} J^T)^{-1} \big[\,0;\ \dot X_d + K (X_d - X)\big] + H z,
    \qquad H = W_0^{-1} - W^{-1} J^T (J W^{-1} J^T)^{-1} J W_0^{-1}

(eq. (23) as we correct it, so that J H = 0; the printed form ends in J W_0), W = W_0^T W_0 =
diag(w), w_i = b_i / b_max from the coordinate ranges b_i (platform x, y: 10 m by default, other
platform coordinates 2 pi; arm: the joint limits). Eq. (27) writes the same solution through the SVD
:math:`J W_0^{-1} = U \Sigma V^T`:
:math:`\dot q = W_0^{-1} V \Sigma^+ U^T [\dots] + W_0^{-1}(I - V \Sigma^+ \Sigma V^T) z`;
:meth:`WeightedPseudoinverse.svd_velocity` implements that form in NumPy (reference and
benchmark baseline), while the compiled step uses the equal closed form above (one CasADi
call per step, no SVD). z = -beta1 dV1/dq - beta2 dV2/dq (eqs. (28)-(29)) with the joint-limit
potential V1 (eq. (30)) and the obstacle potential V2 (eqs. (31)-(32)) over the robot's
collision spheres (:mod:`mmplan.planners.tracking.potentials`). Integration: Heun's
explicit trapezoid rule with step dt (:func:`~mmplan.planners.tracking.rollout.compile_step`);
the paper does not say which integrator it used.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import casadi as ca
import numpy as np

from mmplan.arrays import Array
from mmplan.errors import InputError
from mmplan.planners.tracking.potentials import (
    floor_distances,
    joint_limit_potential,
    obstacle_potential,
)
from mmplan.planners.tracking.rollout import compile_step
from mmplan.planners.tracking.settings import PseudoinverseSettings
from mmplan.planners.tracking.slots import Slots, baked
from mmplan.robot.robot import Robot
from mmplan.scene.obstacle import Obstacle


def coordinate_weights(robot: Robot, platform_range: Sequence[float] | None) -> Array:
    """w_i = b_i / b_max ([AbdessemedDjebrani] eq. (18)), b_i the range of coordinate i, (n,).

    Raises:
        InputError: wrong number of platform ranges, or an unbounded arm joint.
    """
    if platform_range is None:
        platform_range = [10.0 if i < 2 else 2 * np.pi for i in range(robot.n_platform)]
    if len(platform_range) != robot.n_platform:
        raise InputError(
            "planner.platform_range",
            f"expected {robot.n_platform} ranges {robot.platform_coordinates}, "
            f"got {len(platform_range)}",
        )
    arm = robot.limits.joint_max - robot.limits.joint_min
    if not np.isfinite(arm).all():
        raise InputError("limits.joints", "the pseudoinverse weights need finite arm joint limits")
    b = np.concatenate([np.asarray(platform_range, dtype=float), arm])
    if (b <= 0).any():
        raise InputError("limits.joints", f"every coordinate range must be positive, got {b}")
    return np.asarray(b / b.max(), dtype=float)


#: Attributes a loaded model builds on first use (the symbolic model's functions).
LIBRARY_LAZY = ("null_projector", "null_vector", "potentials", "velocity")


class WeightedPseudoinverse:
    """Compiled model of [AbdessemedDjebrani] eqs. (22)-(32) for one robot, scene and settings.

    Attributes:
        w: Weights w_i (n,).
        task_jacobian: CasADi q -> J = [A; J_m] ((h + 3), n).
        null_projector: CasADi q -> H (n, n).
        null_vector: CasADi q -> z = -beta1 dV1/dq - beta2 dV2/dq (n,).
        potentials: CasADi q -> (V1, V2, d_min).
        velocity: CasADi (q, X_d, dX_d) -> dq (eq. (24), closed form).
        step: CasADi [q; r(t); r(t + dt)] -> [q_next; dq; ee; err; sigma; clearance],
            r = [X_d; dX_d]
            (one control step, :func:`~mmplan.planners.tracking.rollout.compile_step`).
    """

    def __init__(
        self, robot: Robot, obstacles: Sequence[Obstacle], settings: PseudoinverseSettings,
        ground: float | None = None, slots: Slots | None = None,
        loaded: Sequence[ca.Function] | None = None,
    ) -> None:
        self.robot = robot
        self.settings = settings
        self.w = coordinate_weights(robot, settings.platform_range)
        self.params = (
            slots.pack(obstacles, settings.d0) if slots is not None else np.zeros(0)
        )  # fmt: skip
        self._scene = (obstacles, ground, slots)
        if loaded is not None:  # the compiled step and Jacobian (compiled.py): no model built
            self.step, self.task_jacobian = loaded
        else:
            self._build()

    def __getattr__(self, name: str) -> Any:
        """The symbolic functions of a loaded model, built when first asked for."""
        if name in LIBRARY_LAZY and "_built" not in self.__dict__:
            self._build()
            return getattr(self, name)
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def library_functions(self) -> list[ca.Function]:
        """What the compiled library holds: the step and the task Jacobian."""
        return [self.step, self.task_jacobian]

    def _build(self) -> None:
        robot, settings = self.robot, self.settings
        obstacles, ground, slots = self._scene
        # the obstacles: numbers in the step's input (slots) or built in
        p_obs = ca.SX.sym("obstacles", slots.size if slots is not None else 0)
        terms = slots.terms(p_obs) if slots is not None else baked(obstacles)
        s = robot.symbols
        q, h = s.q, robot.h
        J = ca.vertcat(s.pfaffian, s.jacobian)  # (h + 3, n)
        lim = robot.limits
        V1 = joint_limit_potential(q, robot.arm_indices, lim.joint_min, lim.joint_max)
        V2, d_min = obstacle_potential(
            s.collision_points,
            robot.collision_radii,
            terms,
            settings.k1,
            settings.d0,
            settings.d_floor,
            floor_distances(robot, ground),  # the floor z = ground (None: none)
        )
        z = -settings.beta1 * ca.gradient(V1, q) - settings.beta2 * ca.gradient(V2, q)
        w_inv = ca.DM(np.diag(1.0 / self.w))
        w0_inv = ca.DM(np.diag(1.0 / np.sqrt(self.w)))
        G = J @ w_inv @ J.T  # (h + 3, h + 3)
        G_inv = ca.solve(G, ca.SX.eye(h + 3))
        H = w0_inv - w_inv @ J.T @ G_inv @ J @ w0_inv
        keep = self.__dict__.setdefault  # a loaded step and Jacobian stay the compiled ones
        keep("task_jacobian", ca.Function("task_jacobian", [q], [J]))
        self.null_projector = ca.Function("null_projector", [q], [H])
        fixed = ca.DM(self.params)  # the functions of q alone see this scene's numbers
        z_q, V2_q, d_q = (ca.substitute(e, p_obs, fixed) for e in (z, V2, d_min))
        self.null_vector = ca.Function("null_vector", [q], [z_q])
        self.potentials = ca.Function("potentials", [q], [V1, V2_q, d_q])

        xd, dxd = ca.SX.sym("X_d", 3), ca.SX.sym("dX_d", 3)
        err = xd - s.ee_position
        rhs = ca.vertcat(ca.SX.zeros(h), dxd + settings.gain * err)
        dq = w_inv @ J.T @ (G_inv @ rhs) + w0_inv @ z - w_inv @ J.T @ (G_inv @ (J @ (w0_inv @ z)))
        # sigma_min(J W0^-1)^2 = 1 / lambda_max(G^-1) >= 1 / trace(G^-1): a lower bound within
        # a factor sqrt(h + 3) of the exact value.
        sigma = 1.0 / ca.sqrt(ca.trace(G_inv))
        aux = ca.vertcat(s.ee_position, ca.norm_2(err), sigma, d_min)
        self.velocity = ca.Function(
            "pinv_velocity", [q, xd, dxd], [ca.substitute(dq, p_obs, fixed)]
        )
        keep(
            "step",
            compile_step("pinv_step", q, ca.vertcat(xd, dxd), dq, aux, robot.n, settings.dt, p_obs),
        )
        self._built = True

    def svd_velocity(self, q: Array, xd: Array, dxd: Array) -> Array:
        """dq by [AbdessemedDjebrani] eq. (27) through the SVD of J W0^-1
        (NumPy reference), (n,)."""
        robot = self.robot
        J = np.asarray(self.task_jacobian(q), dtype=float)
        z = np.asarray(self.null_vector(q), dtype=float).ravel()
        drift = self.settings.gain * (xd - robot.ee_position(q))
        rhs = np.concatenate([np.zeros(robot.h), dxd + drift])
        w0_inv = 1.0 / np.sqrt(self.w)
        U, S, Vt = np.linalg.svd(J * w0_inv[None, :], full_matrices=False)
        particular = w0_inv * (Vt.T @ ((U.T @ rhs) / S))
        homogeneous = w0_inv * (z - Vt.T @ (Vt @ z))
        return np.asarray(particular + homogeneous, dtype=float)

    def smallest_singular_value(self, q: Array) -> float:
        """Exact sigma_min(J(q) W0^-1)."""
        J = np.asarray(self.task_jacobian(q), dtype=float)
        return float(np.linalg.svd(J / np.sqrt(self.w)[None, :], compute_uv=False).min())
