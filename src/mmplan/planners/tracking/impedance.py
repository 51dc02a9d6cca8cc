r"""Virtual impedance for an omnidirectional mobile manipulator ([AbdessemedDjebrani] s.3).

Implements [AbdessemedDjebrani] eqs. (33)-(42); our readings are in docs/tracking.md.
The end-effector task :math:`\xi` (3) and the additional task :math:`\xi_{add}` = platform pose
(x, y, theta) are stacked, :math:`\dot\xi_t = J_t u` with :math:`J_t = [J;\ J_{add}]`
(eq. (36)), and the control is (eq. (37), u ordered as our q: platform first, then arm)

.. math:: u = J_t^{-1}\big(\dot\xi_d^* + W_t(\xi_d^* - \xi_t)\big).

Obstacles act on the platform x, y through the virtual impedance (eqs. (38)-(42)): the
reference is :math:`\xi_d^* = \xi_t^* + F_{ext}/Z_d` with :math:`Z_d = B_d s + K_d` (no
mass term, as the paper's interaction impedance), i.e. the correction
:math:`\delta` = F_ext / Z_d obeys :math:`B_d \dot\delta + K_d \delta = F_{ext}` and
enters the reference velocity as :math:`\dot\delta`. F_ext is the sum of the obstacle forces
(F_target = 0 and F_man = 0: the paper uses only the obstacle force; attraction is the
tracking term itself), each along the outward normal of the obstacle with magnitude

.. math::
    F_{obs}(d) = a_{obs} - b_{obs}(d - d_{min})^2 \ (d_{min} < d < d_{max}),\quad
    a_{obs}\ (d \le d_{min}),\quad 0\ (d \ge d_{max}),\quad a_{obs} = b_{obs}(d_{max} - d_{min})^2,

d the horizontal distance from the platform centre to the obstacle's surface
(:meth:`~mmplan.scene.obstacle.Obstacle.horizontal_distance_sym`; a point obstacle is a
thin post). Reading of the platform task (ours, docs/tracking.md):
:math:`\xi_p^*(t)` = (X_d,x(t) + o_x, X_d,y(t) + o_y, heading) with the offset o and heading
from the settings; the example's "(t, t, pi/4)" is read as (0.1 t, 0.1 t, pi/4). ``b_obs = 0``
switches the impedance off.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import casadi as ca
import numpy as np

from mmplan.arrays import Array
from mmplan.errors import InputError
from mmplan.planners.tracking.potentials import (
    floor_distances,
    min_clearance_sym,
    sphere_distances,
)
from mmplan.planners.tracking.rollout import compile_step
from mmplan.planners.tracking.settings import ImpedanceSettings
from mmplan.planners.tracking.slots import Slots, baked
from mmplan.robot.robot import Robot
from mmplan.scene.obstacle import Obstacle
from mmplan.task import TrackPath


def obstacle_force_magnitude(d: ca.SX, d_min: float, d_max: float | ca.SX, b_obs: float) -> ca.SX:
    """|F_obs|(d) of [AbdessemedDjebrani] s.3.3 (Borenstein & Koren),
    saturated below d_min, 0 beyond d_max."""
    a_obs = b_obs * (d_max - d_min) ** 2
    inner = a_obs - b_obs * (d - d_min) ** 2
    return ca.if_else(d >= d_max, 0, ca.if_else(d <= d_min, a_obs, inner))


class VirtualImpedance:
    """Compiled model of [AbdessemedDjebrani] eqs. (36)-(42) for one robot, scene and settings.

    Attributes:
        force: CasADi q -> (F_ext (2,), d_min): obstacle force on the platform and the
            smallest horizontal platform-obstacle distance.
        task_matrix: CasADi q -> J_t (6, n).
        step: CasADi [q; delta; r(t); r(t + dt)] -> [q_next; delta_next; dq; ee; err; sigma;
            clearance] with r = [xi* (3); dxi* (3); xi_p* (3); dxi_p* (3)] and the clearance
            of the robot's collision spheres.
    """

    def __init__(
        self, robot: Robot, obstacles: tuple[Obstacle, ...], settings: ImpedanceSettings,
        ground: float | None = None, slots: Slots | None = None,
        loaded: Sequence[ca.Function] | None = None,
    ) -> None:
        if robot.h != 0 or robot.n_platform != 3 or robot.n < 6:
            raise InputError(
                "robot",
                "impedance needs an omnidirectional platform (x, y, theta) "
                f"and >= 3 arm joints; {robot.name} has h = {robot.h}, "
                f"platform {robot.platform_coordinates}",
            )
        self.robot = robot
        self.settings = settings
        self.params = (
            slots.pack(obstacles, settings.d_max) if slots is not None else np.zeros(0)
        )  # fmt: skip
        if loaded is not None:  # the compiled functions (compiled.py): no model built
            self.step, self.task_matrix, self.force_p = loaded
        else:
            self._build(obstacles, ground, slots)
        q = ca.MX.sym("q", robot.n)  # the force of this scene's obstacles
        F, d = self.force_p(q, ca.DM(self.params))
        self.force = ca.Function("impedance_force", [q], [F, d])

    def library_functions(self) -> list[ca.Function]:
        """What the compiled library holds: the step, the task matrix and the force."""
        return [self.step, self.task_matrix, self.force_p]

    def _build(
        self, obstacles: Sequence[Obstacle], ground: float | None, slots: Slots | None
    ) -> None:
        robot, settings = self.robot, self.settings
        s = robot.symbols
        q, n = s.q, robot.n
        delta = ca.SX.sym("delta", 2)
        ref = ca.SX.sym("ref", 12)
        # the obstacles: numbers in the step's input (slots) or built in
        p_obs = ca.SX.sym("obstacles", slots.size if slots is not None else 0)
        terms = slots.terms(p_obs) if slots is not None else baked(obstacles)
        # Obstacle force on the platform centre (floor level), eqs. (39) and section 3.3.
        p = ca.SX.sym("p", 3)
        F = ca.SX.zeros(2)
        d_min = ca.SX(1e3)
        for term in terms:
            d_max = term.influence if term.influence is not None else settings.d_max
            d = term.horizontal(p)
            grad = ca.gradient(d, p)[:2]
            normal = grad / ca.sqrt(ca.sumsqr(grad) + 1e-18)
            reach = ca.fmax(d_max, settings.d_min + 1e-9)  # a number or a slot's parameter
            mag = obstacle_force_magnitude(d, settings.d_min, reach, settings.b_obs)
            F += term.gate(mag * normal)  # a parked slot pushes nothing (slots.py)
            d_min = ca.fmin(d_min, term.seen(d))
        at_platform = ca.Function("f", [p, p_obs], [F, d_min])
        F_q, d_q = at_platform(ca.vertcat(q[0], q[1], 0), p_obs)
        self.force_p = ca.Function("impedance_force_p", [q, p_obs], [F_q, d_q])
        # Impedance filter B_d d' + K_d d = F_ext (eq. (41) with Z_d = B_d s + K_d).
        ddelta = (F_q - settings.stiffness * delta) / settings.damping
        shift = ca.vertcat(ca.SX.zeros(3), delta, 0)
        dshift = ca.vertcat(ca.SX.zeros(3), ddelta, 0)
        xi_ref = ca.vertcat(ref[0:3], ref[6:9]) + shift  # xi_d* (eq. (42))
        dxi_ref = ca.vertcat(ref[3:6], ref[9:12]) + dshift
        J_t = ca.vertcat(s.jacobian, ca.horzcat(ca.SX.eye(3), ca.SX.zeros(3, n - 3)))  # eq. (36)
        xi_t = ca.vertcat(s.ee_position, q[0:3])
        rhs = dxi_ref + settings.gain * (xi_ref - xi_t)
        if n == 6:
            J_inv = ca.solve(J_t, ca.SX.eye(6))  # eq. (37)
        else:  # more arm joints: minimum-norm solution
            J_inv = J_t.T @ ca.solve(J_t @ J_t.T, ca.SX.eye(6))
        u = J_inv @ rhs
        # sigma_min(J_t) = 1 / |J_t^-1|_2 >= 1 / |J_t^-1|_F (within a factor sqrt(6)).
        sigma = 1.0 / ca.sqrt(ca.sumsqr(J_inv))
        err = ca.norm_2(ref[0:3] - s.ee_position)
        self.task_matrix = ca.Function("task_matrix", [q], [J_t])
        state = ca.vertcat(q, delta)
        pairs = sphere_distances(s.collision_points, robot.collision_radii, terms)
        floor = floor_distances(robot, ground)  # checked (stop rule), not avoided: no null space
        aux = ca.vertcat(s.ee_position, err, sigma, min_clearance_sym(pairs, floor))
        self.step = compile_step(
            "impedance_step", state, ref, ca.vertcat(u, ddelta), aux, n, settings.dt, p_obs
        )

    def reference(self, task: TrackPath, t: float) -> Array:
        """r(t) = [xi*(t); dxi*(t); xi_p*(t); dxi_p*(t)] (12,) (our reading of xi_p*)."""
        x, v = task.position(t), task.velocity(t)
        o = self.settings.platform_offset
        pose = np.array([x[0] + o[0], x[1] + o[1], self.settings.platform_heading])
        dpose = np.array([v[0], v[1], 0.0])
        return np.concatenate([x, v, pose, dpose])

    def smallest_singular_value(self, q: Array) -> float:
        """Exact sigma_min(J_t(q))."""
        J_t = np.asarray(self.task_matrix(q), dtype=float)
        return float(np.linalg.svd(J_t, compute_uv=False).min())


def platform_distances(
    model: VirtualImpedance,
    task: TrackPath,
    t: Array,
    q: Array,
    distance: Callable[[Array], Array] | None = None,
) -> dict[str, float]:
    """Horizontal platform-centre distances to the nearest obstacle surface [m].

    ``min_platform_obstacle_distance_m`` is the minimum over the run;
    ``platform_obstacle_distance_at_pass_m`` is the distance at the pass: the time at which
    the undisturbed platform reference comes closest to an obstacle (the measure [RefRuns]
    compares with and without impedance). ``distance``: states (N, n) -> the nearest
    obstacle's horizontal distance (N,), for a scene the model's parameters do not hold
    whole (:mod:`.active`); default: the model's force function.
    """
    if distance is None:
        mapped = model.force.map(len(q))

        def distance(x: Array) -> Array:
            return np.asarray(mapped(x.T)[1], dtype=float).ravel()

    actual = distance(q)
    q_ref = q.copy()
    q_ref[:, :2] = np.array([model.reference(task, float(s))[6:8] for s in t])
    reference = distance(q_ref)
    k = int(np.argmin(reference))
    return {
        "min_platform_obstacle_distance_m": float(actual.min()),
        "platform_obstacle_distance_at_pass_m": float(actual[k]),
        "pass_time_s": float(t[k]),
    }
