r"""The floor as an extra output of the endogenous planner ([JaniakTchon] s.II, our addition).

The floor z = h (``Scene.ground``) applies to the ground spheres
(:func:`~mmplan.robot.ground.ground_sphere_indices`), whose heights depend on the arm joints
only (the platform moves in the plane). The planner's arm follows the blend
:math:`x(s) = x_0 + s\,(x - x_0)`, s in [0, 1] (:mod:`.output`), so the floor clearance of the
whole plan is a function of the final arm joints x alone:

.. math::
    c(x) = \min_{k, i}\ c_i\big(x_0 + s_k (x - x_0)\big), \qquad
    e_f(x) = \min\big(0,\ c(x) - m\big)

over the blend values :math:`s_k` of the trajectory's samples and the ground spheres i, with
:math:`c_i` the height above the floor (:func:`~mmplan.robot.ground.floor_clearance_sym`) and
the margin m = ``FLOOR_MARGIN`` (the checker also checks the motion between samples). Like the
bound outputs of [JaniakTchon] eq. (18), :math:`e_f` is appended to the error e_r while it is
active (< 0), with its Jacobian row :math:`(0_\lambda,\ s_k \nabla_x c_i)` at the worst
(k, i), so that the theta-iteration drives it to zero together with the task error; the row is
left out while the plan keeps clear (a zero row would make J singular) and when it lies in
the row space of the other outputs' Jacobian (e.g. the worst point is the end effector at
t = T: the task output already fixes its height).

The iteration first runs as in [JaniakTchon], without this output; only when its plan comes
closer than the margin to the floor does it go on from there with the output (a second
phase). A plan that keeps clear is thus exactly the paper method's; the active output does not
change the iterates that never needed it.
"""

from __future__ import annotations

from collections.abc import Sequence

import casadi as ca
import numpy as np

from mmplan.arrays import Array
from mmplan.planners.endogenous.output import blend, wrap_arm
from mmplan.problem import Problem
from mmplan.robot.ground import floor_clearance_sym, floor_clearances, ground_sphere_indices
from mmplan.robot.robot import Robot
from mmplan.trajectory import Status

#: Clearance [m] the iteration keeps above the floor (e_f = 0 from there on).
FLOOR_MARGIN = 0.01


class FloorOutput:
    """e_f and its Jacobian row for one robot, floor height, start and sample grid.

    Args:
        robot: The robot (its ground spheres).
        ground: Floor height h [m].
        start: The full start q0 (n,); its platform part stands in for the platform (the
            ground spheres' heights do not depend on it).
        times: The trajectory's sample times on [0, T] (N,).
        horizon: T [s].
        bounded: Robot indices of the arm joints with a state bound (not wrapped).
    """

    def __init__(self, robot: Robot, ground: float, start: Array, times: Array,
                 horizon: float, bounded: Sequence[int]) -> None:
        q = robot.symbols.q
        c = floor_clearance_sym(robot, ground)  # (G, 1)
        self.robot = robot
        self.start = np.asarray(start, dtype=float)
        self.n_p = robot.n_platform
        self.bounded = list(bounded)
        self.s = np.unique(np.clip(blend(np.asarray(times, float), horizon)[0], 0.0, 1.0))
        self.values = ca.Function("floor_values", [q], [c]).map(len(self.s))
        self.gradient = ca.Function("floor_gradient", [q], [ca.jacobian(c, q)])  # (G, n)

    @classmethod
    def of(cls, robot: Robot, ground: float | None, start: Array, times: Array,
           horizon: float, bounded: Sequence[int]) -> FloorOutput | None:
        """The floor output, or None without a floor or without ground spheres."""
        if ground is None or not ground_sphere_indices(robot):
            return None
        return cls(robot, ground, start, times, horizon, bounded)

    def clearance(self, x: Array) -> tuple[float, int, int]:
        """c(x) of the module doc and where: (value, blend index k, sphere index i)."""
        x0 = self.start[self.n_p:]
        x = wrap_arm(self.robot, x0, x, self.bounded)
        q = np.repeat(self.start[None, :], len(self.s), axis=0)
        q[:, self.n_p:] = x0[None, :] + self.s[:, None] * (x - x0)[None, :]
        c = np.asarray(self.values(q.T), dtype=float)  # (G, K)
        i, k = (int(v) for v in np.unravel_index(int(np.argmin(c)), c.shape))
        return float(c[i, k]), k, i

    def row(self, x: Array) -> tuple[float, Array] | None:
        """(e_f, d e_f / dx (n_x,)) while the output is active (e_f < 0), else None."""
        value, k, i = self.clearance(x)
        if value >= FLOOR_MARGIN:
            return None
        x0 = self.start[self.n_p:]
        q = self.start.copy()
        q[self.n_p:] = x0 + self.s[k] * (wrap_arm(self.robot, x0, x, self.bounded) - x0)
        grad = np.asarray(self.gradient(q), dtype=float)[i, self.n_p:]  # d c_i / d x at s_k
        return value - FLOOR_MARGIN, self.s[k] * grad


def independent(J: Array, row: Array, rtol: float = 1e-6) -> bool:
    """``row`` (m,) is not (nearly) in the row space of ``J`` (k, m): its residual after the
    least-squares projection onto that space exceeds ``rtol`` |row|."""
    coef = np.linalg.lstsq(J.T, row, rcond=None)[0]
    return bool(np.linalg.norm(row - J.T @ coef) > rtol * max(float(np.linalg.norm(row)), 1e-300))


def floor_verdict(
    problem: Problem, q: Array, t: Array, status: Status, message: str
) -> tuple[Status, str, dict[str, float]]:
    """A reached plan whose ground spheres reach below the floor at a sample is infeasible;
    info ``min_floor_clearance_m`` (none without a floor)."""
    ground = problem.scene.ground
    gaps = floor_clearances(problem.robot, q, ground) if ground is not None else np.zeros((0, 0))
    if gaps.size == 0:
        return status, message, {}
    k = int(np.argmin(gaps.min(axis=1)))
    low = float(gaps[k].min())
    if low < 0 and status is Status.REACHED:
        status = Status.INFEASIBLE
        message += (f"; but the arm reaches {-low:.4g} m below the floor z = {ground:g} at "
                    f"t = {t[k]:.4g} s (the floor output could not keep it clear)")
    return status, message, {"min_floor_clearance_m": low}


__all__ = ["FLOOR_MARGIN", "FloorOutput", "floor_verdict", "independent"]
