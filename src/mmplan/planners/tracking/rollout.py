r"""Closed-loop rollout shared by the path-tracking planners ([AbdessemedDjebrani]).

A tracking planner compiles its whole control step into one CasADi ``Function``
``step(v) -> w`` on packed vectors (one call per step from Python):

* input ``v = [s; r(t); r(t + dt)]``: the planner state s (q, possibly followed by filter
  states) and the reference r evaluated in Python (task position/velocity) at both ends of
  the step;
* output ``w = [s_next; dq; ee; err; sigma; clearance]``: the successor state by Heun's
  explicit trapezoid rule (:math:`\tilde s = s_k + \Delta t f(s_k, t_k)`,
  :math:`s_{k+1} = s_k + \tfrac{\Delta t}{2}(f(s_k, t_k) + f(\tilde s, t_{k+1}))`), the
  velocity :math:`\dot q_k = f_q(s_k, t_k)`, the end-effector position and tracking error at
  :math:`q_k`, a lower bound ``sigma`` of the smallest singular value of the solved matrix,
  and the planner's clearance: the smallest signed distance from a collision sphere to an
  obstacle in the planner's geometry (exact for spheres, cylinders and boxes).

The trapezoid rule makes q consistent with the sampled dq to second order (the checker's
trapezoid test); ddq is the central difference of dq.

:func:`rollout` runs the loop and stops honestly (stalled / diverged) when the matrix becomes
singular, the error grows beyond a limit, an arm joint leaves its limits, the robot
touches an obstacle (optional), or a value is not finite;
:func:`mmplan.planners.tracking.result.finish` turns the samples into a result.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import casadi as ca
import numpy as np

from mmplan.arrays import Array
from mmplan.planners.tracking.active import TrackerSlots
from mmplan.planners.tracking.settings import TrackingSettings
from mmplan.problem import Progress
from mmplan.robot.robot import Robot
from mmplan.trajectory import Status

#: Steps between the checks of the obstacles left out of the slots (:func:`rollout`).
BLOCK = 50


@dataclass(frozen=True)
class StopRules:
    """When a rollout gives up.

    Attributes:
        min_singular_value: Stop (stalled) when the smallest singular value of the solved
            matrix falls below this.
        max_error: Stop (diverged) when the tracking error exceeds the initial error by more
            than this [m].
        stop_on_collision: Stop (stalled) when the planner's clearance becomes negative.
    """

    min_singular_value: float
    max_error: float
    stop_on_collision: bool = True

    @classmethod
    def of(cls, settings: TrackingSettings) -> StopRules:
        """The stop rules a tracker's settings state."""
        return cls(settings.min_singular_value, settings.max_error, settings.stop_on_collision)

    def verdict(
        self,
        t: float,
        state: Array,
        aux: Array,
        e0: float,
        robot: Robot,
        exact_sigma: Callable[[Array], float],
    ) -> tuple[Status, str] | None:
        """Why the rollout must stop at this sample (None: go on).

        Args:
            t: Sample time [s].
            state: Planner state (q first).
            aux: [ee (3); err; sigma; clearance] of the sample.
            e0: Tracking error at t = 0 [m].
            robot: The robot (arm limits, names).
            exact_sigma: q -> exact smallest singular value (called only near the threshold).
        """
        err, sigma, clearance = aux[3], aux[4], aux[5]
        q = state[: robot.n]
        if sigma < self.min_singular_value:
            exact = exact_sigma(q)
            if exact < self.min_singular_value:
                return Status.STALLED, (
                    f"Jacobian singular at t = {t:.3f} s: smallest singular value "
                    f"{exact:.2e} < {self.min_singular_value:g} (task out of reach?)"
                )
        if err > e0 + self.max_error:
            return Status.DIVERGED, (
                f"tracking error {err:.3f} m at t = {t:.3f} s grew beyond the initial "
                f"{e0:.3f} m + max_error {self.max_error:g} m"
            )
        if self.stop_on_collision and clearance < 0:
            return Status.STALLED, (
                f"collision at t = {t:.3f} s (clearance {clearance:.3f} m): obstacle avoidance "
                "could not keep the robot off the obstacles (local minimum of the potential?)"
            )
        arm = list(robot.arm_indices)
        qa = q[arm]
        lim = robot.limits
        bad = np.flatnonzero((qa < lim.joint_min - 1e-9) | (qa > lim.joint_max + 1e-9))
        if bad.size:
            i = int(bad[0])
            return Status.STALLED, (
                f"joint {robot.coordinates[arm[i]]} left its limits at t = {t:.3f} s ({qa[i]:.3f})"
            )
        return None


@dataclass
class Rollout:
    """Samples of a rollout (k = 0..N-1) and how it ended."""

    t: Array
    q: Array
    dq: Array
    ee: Array
    error: Array
    sigma: Array
    clearance: Array  # planner model, 1e3 without obstacles
    status: Status | None  # None: ran to the end of the path
    message: str


def compile_step(
    name: str,
    state: ca.SX,
    ref: ca.SX,
    rate: ca.SX,
    aux: ca.SX,
    n: int,
    dt: float,
    params: ca.SX | None = None,
) -> ca.Function:
    """One Heun step of ds/dt = rate(s, r, p) as a single CasADi function (see module docstring).

    Args:
        name: Function name.
        state: Symbolic state s (ns,), q first.
        ref: Symbolic reference r (nr,).
        rate: ds/dt as an expression of (state, ref) (ns,).
        aux: [ee (3); err; sigma; clearance] as an expression of (state, ref) (6,).
        n: Number of coordinates (dq = rate[:n]).
        dt: Step [s].
        params: Symbolic parameters p the expressions depend on (the obstacles' numbers,
            :mod:`.slots`), last in the input; None: none.
    """
    p = params if params is not None else ca.SX.sym("p", 0)
    f = ca.Function(f"{name}_rate", [state, ref, p], [rate, aux])
    s = ca.SX.sym("s", state.shape[0])
    r0, r1 = ca.SX.sym("r0", ref.shape[0]), ca.SX.sym("r1", ref.shape[0])
    pp = ca.SX.sym("p", p.shape[0])
    k1, aux1 = f(s, r0, pp)
    k2, _ = f(s + dt * k1, r1, pp)
    out = ca.vertcat(s + 0.5 * dt * (k1 + k2), k1[:n], aux1)
    return ca.Function(name, [ca.vertcat(s, r0, r1, pp)], [out])


class BufferedStep:
    """Calls a one-input, one-output CasADi function through its zero-copy buffer.

    ``Function.buffer()`` (CasADi >= 3.6) evaluates into preallocated NumPy arrays, which
    removes most of the Python-side conversion cost of ``f(v)`` (the per-step budget of a
    10 kHz loop is 100 us). Falls back to the plain call when the buffer API is missing.
    """

    def __init__(self, fn: ca.Function) -> None:
        self.fn = fn
        self.inp = np.zeros(fn.size1_in(0))
        self.out = np.zeros(fn.size1_out(0))
        self._eval: Callable[[], None] | None = None
        if hasattr(fn, "buffer"):
            self._buf, self._eval = fn.buffer()
            # The stubs list a byte size argument; the Python typemap takes it from the
            # memoryview itself (passing it explicitly is rejected at runtime).
            self._buf.set_arg(0, memoryview(self.inp))  # type: ignore[call-arg, arg-type]
            self._buf.set_res(0, memoryview(self.out))  # type: ignore[call-arg, arg-type]

    def __call__(self, v: Array) -> Array:
        """fn(v) as a flat array (a view valid until the next call)."""
        if self._eval is None:
            self.out[:] = np.asarray(self.fn(v), dtype=float).ravel()
        else:
            self.inp[:] = v
            self._eval()
        return self.out


def rollout(
    step: ca.Function,
    state0: Array,
    reference: Callable[[float], Array],
    robot: Robot,
    dt: float,
    steps: int,
    rules: StopRules,
    exact_sigma: Callable[[Array], float],
    progress: Progress = None,
    params: Array | None = None,
    active: TrackerSlots | None = None,
) -> Rollout:
    """Run ``steps + 1`` control steps from ``state0`` (samples at t = k dt, k = 0..steps).

    Args:
        step: Compiled control step (see module docstring).
        state0: Initial planner state (q first).
        reference: t -> reference vector r(t); the step gets [state; r(t); r(t + dt)].
        robot: The robot (coordinates, arm limits).
        dt: Step [s].
        steps: Number of Euler steps.
        rules: Stop rules.
        exact_sigma: q -> exact smallest singular value, called only when the step's lower
            bound falls below the threshold.
        progress: Optional callback with the fraction done.
        params: The step's parameters p (last in its input; :func:`compile_step`).
        active: The scene has more obstacles than the step's slots: which ones p holds is
            chosen along the run (:mod:`.active`; p's slots are chosen again at the start).

    Raises:
        CrowdedError: more obstacles of a kind near at once than slots (only with ``active``).
    """
    n, ns = robot.n, len(state0)
    tail = np.zeros(0) if params is None else np.asarray(params, dtype=float)
    q = np.zeros((steps + 1, n))
    dq = np.zeros((steps + 1, n))
    ee = np.zeros((steps + 1, 3))
    scal = np.zeros((steps + 1, 3))  # err, sigma, clearance
    state = np.asarray(state0, dtype=float).copy()
    status: Status | None = None
    message = ""
    e0 = math.inf
    every = max(1, steps // 100)
    call = BufferedStep(step)
    r_next = reference(0.0)
    # more obstacles than slots (active.py): the states since ``base`` are checked against
    # the obstacles left out every BLOCK steps and at the end; the run goes back to the last
    # state whose step kept away from them
    states = np.zeros((steps + 1, ns)) if active is not None else None
    if active is not None:
        tail = active.start(tail, state[:n])
    base, retries, k = 0, 0, 0
    while k <= steps:
        t = k * dt
        r_now, r_next = r_next, reference((k + 1) * dt)
        out = call(np.concatenate([state, r_now, r_next, tail])).copy()
        stop: tuple[Status, str] | None = None
        if not np.isfinite(out).all():
            stop = Status.DIVERGED, f"non-finite velocity at t = {t:.3f} s"
        else:
            aux = out[ns + n : ns + n + 6]
            e0 = aux[3] if k == 0 else e0
            stop = rules.verdict(t, state, aux, e0, robot, exact_sigma)
        if stop is None:
            q[k], dq[k], ee[k] = state[:n], out[ns : ns + n], out[ns + n : ns + n + 3]
            scal[k] = out[ns + n + 3 : ns + n + 6]
            if states is not None:
                states[k] = state
            state = out[:ns]
            if progress is not None and k % every == 0:
                progress(k / max(steps, 1))
            k += 1
        if active is not None and states is not None and (
            stop is not None or k - base >= BLOCK or k > steps
        ):
            # states base..k (the state after the last sample only steps nowhere: left out)
            # with Heun's predictor q_j + dt dq_j between them (a review: a large gain x dt
            # may put it beyond the next state)
            ends = np.vstack([q[base:k], state[None, :n]])[: min(k, steps) - base + 1]
            path = np.empty((2 * len(ends) - 1, n))
            path[0::2] = ends
            path[1::2] = ends[:-1] + dt * dq[base : base + len(ends) - 1]
            v = active.first_unsafe(path)
            if v < len(path):  # back to the last state whose step kept away, chosen there
                keep = max(base + (v - 1) // 2, base)
                retries = retries + 1 if keep == base else 0
                if retries > active.count:
                    raise active.stuck()
                state = states[keep].copy() if keep < k else state
                tail = active.choose(tail, state[None, :n])
                k = base = keep
                r_next = reference(k * dt)
                continue
            base, retries = k, 0
        if stop is not None:
            status, message = stop
            break
    m = max(k, 1)
    if k == 0:  # stopped at the very first sample: keep the start at rest
        q[0], ee[0] = np.asarray(state0, dtype=float)[:n], robot.ee_position(np.asarray(state0)[:n])
        scal[0, 0] = float(np.linalg.norm(reference(0.0)[:3] - ee[0]))
        scal[0, 1:] = np.nan
    t_arr = dt * np.arange(m, dtype=float)
    return Rollout(
        t_arr, q[:m], dq[:m], ee[:m], scal[:m, 0], scal[:m, 1], scal[:m, 2], status, message
    )
