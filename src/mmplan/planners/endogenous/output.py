"""Arm coordinates and the trajectory of an endogenous configuration (lambda, x) ([JaniakTchon]).

Bounded arm joints: in [JaniakTchon] the arm joints x are constants of the end point map. The
paper's extra state (eq. (18)) with its regularizer r(x_k) then pins a bounded joint: the
Wazewski-Davidenko equation (13) asks the output T (r(x_k) + p + p) to follow only the small
penalty error, and nothing but x_k moves it, so x_k stays put (measured: 3 of 5 random plans
with a bound on x2 stalled that way). A bound on an arm joint is therefore realised by the
saturating coordinate x_k = c + h tanh(xi_k) (c the centre, h the half width of the bound),
the theta-iteration running in xi_k (:class:`ArmBox`); the joint then stays strictly inside.

The platform follows the controls u(t) = P(t) lambda from the platform start (the RK4 grid of
:class:`~mmplan.planners.endogenous.model.EndogenousModel`); dq_p = G(q_p) u and
ddq_p = (dG/dq dq_p) u + G du/dt are analytic in the controls.

In [JaniakTchon] the arm configuration x is a constant of the end point map: only its value at
t = T matters. So that the trajectory starts at the given start q0 (arm part x0), the arm moves
from x0 to x along a quintic rest-to-rest blend s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5,
tau = t / T, which leaves the end point (and the task error) unchanged. A revolute arm joint
without a state bound is first wrapped to the angle equivalent to x that lies nearest x0
(the theta-iteration can wind it by several turns; the end point map is 2 pi periodic in it).
Columns ``u1``, ``u2``, ... hold the platform controls.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from mmplan.arrays import Array
from mmplan.planners.endogenous.model import EndogenousModel, ResolvedBound
from mmplan.robot.robot import Robot
from mmplan.robot.tree import JointKind
from mmplan.trajectory import Trajectory


class ArmBox:
    """Saturating coordinates x_k = c_k + h_k tanh(xi_k) for the bounded arm joints.

    Args:
        n_platform: Number of platform coordinates (bound indices are in robot order).
        n_x: Number of arm joints.
        bounds: Bounds on arm joints only.
    """

    def __init__(self, n_platform: int, n_x: int, bounds: Sequence[ResolvedBound]) -> None:
        self.n_x = n_x
        self.index = np.array([b.index - n_platform for b in bounds], dtype=int)
        self.center = np.array([b.center for b in bounds], dtype=float)
        self.half = np.array([0.5 * (b.upper - b.lower) for b in bounds], dtype=float)

    def to_x(self, xi: Array) -> Array:
        """Arm joints x (n_x,) of the iteration coordinates xi."""
        x = np.array(xi, dtype=float)
        x[self.index] = self.center + self.half * np.tanh(x[self.index])
        return x

    def from_x(self, x: Array) -> Array:
        """Iteration coordinates xi of arm joints x strictly inside their bounds."""
        xi = np.array(x, dtype=float)
        xi[self.index] = np.arctanh((xi[self.index] - self.center) / self.half)
        return xi

    def scale(self, xi: Array) -> Array:
        """dx/dxi (n_x,) (diagonal)."""
        d = np.ones(self.n_x)
        d[self.index] = self.half * (1.0 - np.tanh(np.asarray(xi, float)[self.index]) ** 2)
        return d


def wrap_arm(robot: Robot, x0: Array, x: Array, bounded: Sequence[int]) -> Array:
    """x with every revolute arm joint not in ``bounded`` (indices in robot order) moved by
    whole turns to lie nearest x0."""
    revolute = {j.coordinate for j in robot.tree.joints if j.kind is JointKind.REVOLUTE}
    out = np.array(x, dtype=float)
    for i, name in enumerate(robot.arm_coordinates):
        if name in revolute and robot.n_platform + i not in set(bounded):
            delta = out[i] - x0[i]
            out[i] = x0[i] + (delta + np.pi) % (2 * np.pi) - np.pi
    return out


def blend(t: Array, horizon: float) -> tuple[Array, Array, Array]:
    """Quintic rest-to-rest blend s, ds/dt, d2s/dt2 at times t (N,) on [0, T]."""
    tau = np.asarray(t, float) / horizon
    s = tau**3 * (10 - 15 * tau + 6 * tau**2)
    ds = 30 * tau**2 * (1 - tau) ** 2 / horizon
    dds = 60 * tau * (1 - 3 * tau + 2 * tau**2) / horizon**2
    return s, ds, dds


def stretched(traj: Trajectory, factor: float) -> Trajectory:
    """The same motion re-timed uniformly, t -> factor t: dq / factor, ddq / factor^2 and the
    platform controls u / factor (exact for the driftless platform, dq_p = G(q_p) u, and for
    the arm's blend, which scales with the horizon)."""
    return dataclasses.replace(
        traj,
        t=traj.t * factor,
        dq=traj.dq / factor,
        ddq=traj.ddq / factor**2,
        extra={k: v / factor for k, v in traj.extra.items()},
    )


def build_trajectory(
    robot: Robot, model: EndogenousModel, start: Array, lam: Array, x: Array
) -> Trajectory:
    """Trajectory (the trajectory.csv columns of docs/conventions.md plus u1..um) of (lambda, x)
    from ``start``."""
    n_p = robot.n_platform
    qp, dqp, ddqp, u = model.trajectory(start[:n_p], lam)
    t = model.times()
    s, ds, dds = blend(t, model.horizon)
    x0 = start[n_p:]
    dx = np.asarray(x, float) - x0
    q = np.hstack([qp, x0[None, :] + s[:, None] * dx[None, :]])
    dq = np.hstack([dqp, ds[:, None] * dx[None, :]])
    ddq = np.hstack([ddqp, dds[:, None] * dx[None, :]])
    ee = np.asarray(robot.functions["ee_position"].map(len(t))(q.T), float).T
    return Trajectory(
        coordinates=robot.coordinates,
        t=t,
        q=q,
        dq=dq,
        ddq=ddq,
        ee=ee,
        extra={f"u{i + 1}": u[:, i] for i in range(model.n_u)},
    )
