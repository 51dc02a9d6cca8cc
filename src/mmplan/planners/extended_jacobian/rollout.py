r"""Rollout of the extended-Jacobian generator with virtual control, stall escape and statuses.

One loop step (dt; docs/extended_jacobian.md): evaluate the generator terms at (q, dq)
(:mod:`mmplan.planners.extended_jacobian.generator`), decide the perturbation budget s and the
virtual
control u (:mod:`mmplan.planners.extended_jacobian.torque.virtual_control`), record the sample
(ddq = f0 + u fv + s (fp - S dq) + ext and tau = T0 + Tm ddq, [PajakPajak] eqs. (22), (24)), then
advance one Strang-split RK4 step with u, s, ext held.

Torque limits and obstacles (docs/extended_jacobian.md, feedback mode): [PajakPajak]
eq. (23) as printed scales the push by u, so the
barrier torque saturates the limits, u drops to 0 and the push vanishes. Here the push keeps
its own factor s in [0, 1] (push and damping -S dq of eq. (19) together), chosen first as the
largest value whose efforts fit in the zone with u = 0 (the perturbation "respects the torque
budget"); then u is chosen by cases (a)-(d) with b = T0 + Tm (f0 + ext + s (fp - S dq)).
With s chosen this way u = 0 is always feasible unless the drift f0 = -E^-1 v1 alone leaves
the zone: such samples are counted; a sample outside the true limits makes the run
``infeasible``. Caveat (measured on random scenes): with s < 1 near an obstacle the damping is
cut too and the robot can coast into it; ``time`` mode
(:mod:`~mmplan.planners.extended_jacobian.time_scaling`) avoids this.

Escape from local minima ([PajakPajak] s.3.2 cites it): when the error has not decreased by
``stall_progress`` (nor by a tenth of itself, :meth:`RolloutOptions.stalled`) over
``stall_window`` while an obstacle acts (K > 0), a push along the obstacle
boundary (perpendicular to dK/dq in the platform plane, on the goal's side on odd attempts and the
other side on even ones, with a damped turn of the platform towards it) is applied for
``escape_time``; the next verdict waits a full window. After ``max_escapes`` attempts, or without an
obstacle acting, the run ends as stalled.

Conditioning: cond(E) is computed every ``cond_every`` steps; above ``switch_cond`` the
caller may switch to a better-conditioned column partition (same optimum, [PajakPajak] eq. (11)),
above ``cond_limit`` the run ends as diverged. Speed: stretches without decisions run as one
compiled call of ``cond_every`` steps each (:mod:`mmplan.planners.extended_jacobian.chunks`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mmplan import linalg
from mmplan.arrays import Array
from mmplan.planners.extended_jacobian import chunks as ej_fastpath
from mmplan.planners.extended_jacobian import divergence
from mmplan.planners.extended_jacobian.active import ActiveSlots
from mmplan.planners.extended_jacobian.generator import GeneratorFunctions
from mmplan.planners.extended_jacobian.options import RolloutOptions
from mmplan.planners.extended_jacobian.samples import SampleLog
from mmplan.planners.extended_jacobian.switching import PartitionSwitch
from mmplan.planners.extended_jacobian.torque.decision import decide
from mmplan.trajectory import Status


@dataclass
class RolloutResult:
    """Samples and diagnostics of a rollout (arrays are (N, .))."""

    status: Status
    message: str
    t: Array
    q: Array
    dq: Array
    ddq: Array
    tau: Array
    u: Array
    s: Array
    error: Array
    info: dict[str, Any] = field(default_factory=dict)
    effort: Array | None = None  # [Tm dq, Tg] (N, 2 n_act) when recorded (time scaling)
    w: Array | None = None  # time rate of a re-timed feedback plan (N,) (time_scaling.retime)
    # status and message before the torque verdict of ``finish`` when it made the run
    # infeasible (a re-timing that brings the efforts inside the limits restores them:
    # time_scaling.scale_path)
    outcome: tuple[Status, str] | None = None


def _keep_start(
    rows: SampleLog, t: float, q: Array, dq: Array, tau_g: Array, u: float, err: float
) -> None:
    """A run that diverges at its first sample keeps the start, at rest, holding gravity."""
    if len(rows) == 0:
        tau = np.where(np.isfinite(tau_g), tau_g, 0.0)
        rows.add_one(t, q, dq, np.zeros_like(q), tau, u, 1.0, err)


def _cond(fns: GeneratorFunctions, q: Array, p: Array) -> float | None:
    """cond(E) at q, None when not finite."""
    if not np.all(np.isfinite(q)):
        return None
    E = fns.E_at(q, p)
    return linalg.cond(E) if np.all(np.isfinite(E)) else None


def _projector(A: Array, winv: Array) -> Array:
    """P = I - W^-1 A^T (A W^-1 A^T)^-1 A (wheel metric), (n, n)."""
    WA = winv[:, None] * A.T
    return np.eye(A.shape[1]) - WA @ np.linalg.solve(A @ WA, A)


def rollout(
    fns: GeneratorFunctions,
    pfaffian: Any,
    winv: Array,
    q0: Array,
    p: Array,
    opt: RolloutOptions,
    switch: PartitionSwitch | None = None,
    fast: bool = True,
    dq0: Array | None = None,
    active: ActiveSlots | None = None,
) -> RolloutResult:
    """Run the generator from ``q0`` (at rest, or moving at ``dq0``) towards the goal p[:3]
    until reached or stopped.

    When ``switch`` wants one (cond(E) above ``opt.switch_cond``, or cond(Jc_R) grown:
    :mod:`~mmplan.planners.extended_jacobian.switching`), ``switch(q, factor)`` may return
    the generator of a better-conditioned column partition (same optimum, eq. (11)); the run
    continues with it.
    ``fast=False`` runs every sample in the loop (the reference; same samples to rounding).

    Args:
        fns: Generator functions of the problem.
        pfaffian: Callable q -> A(q) (h, n) (NumPy), for the escape projection.
        winv: Diagonal of W^-1 (n,).
        q0: Start (n,).
        p: Generator parameters (goal, gains, scene: ``fns.layout.pack``).
        opt: Options.
        dq0: Start velocity (n,) (re-planning from a moving state); None: rest.
        active: The scene has more obstacles of a shape type than ``fns`` has slots: which
            ones p holds is chosen along the run (:mod:`~mmplan.planners.extended_jacobian.
            active`; p's slots are chosen again at q0).

    Raises:
        CrowdedError: more obstacles of a type near at once than slots (only with ``active``).
    """
    try:
        return _run(fns, pfaffian, winv, q0, p, opt, switch, fast, dq0, active)
    finally:  # however it ended: the worker thread is the time scaling's (or the caller's)
        fns.settle_guesses()


def _run(
    fns: GeneratorFunctions,
    pfaffian: Any,
    winv: Array,
    q0: Array,
    p: Array,
    opt: RolloutOptions,
    switch: PartitionSwitch | None,
    fast: bool,
    dq0: Array | None,
    active: ActiveSlots | None,
) -> RolloutResult:
    """:func:`rollout`'s loop (its guessed chunks ended by the caller)."""
    n, dt = fns.n, opt.dt
    p = np.array(p, dtype=float)
    if active is not None:
        p = active.start(p, q0)
    p_f = p[:3]
    q, dq = np.array(q0, dtype=float), np.zeros(n) if dq0 is None else np.array(dq0, float)
    if switch is not None:
        switch.start(q)
    u = 0.0 if opt.torque_control else 1.0
    status, message = Status.TIMEOUT, f"t_max = {opt.t_max} s reached before the goal"
    steps = int(np.ceil(opt.t_max / dt))
    rows = SampleLog(steps + 1)
    window = max(1, round(opt.stall_window / dt))
    escape_left, escape_until, escapes, switches = 0, -1.0, 0, 0
    escape_dir: Array | None = None
    max_cond, infeasible_samples, infeasible_first, s_min = 0.0, 0, None, 1.0
    k, chunked = -1, 0
    retries = 0
    while k < steps:
        k += 1
        t = k * dt
        if active is not None and active.flagged:  # an obstacle left out came near
            p = active.choose(p, q[None, :])
        if fast and ej_fastpath.usable(fns, opt, k, steps, escape_dir is None or t >= escape_until):
            clock = ej_fastpath.StallClock(window, escapes, escape_until)
            can_switch = switch is not None and switches < opt.max_switches
            wants = switch.wants if switch is not None and can_switch else None
            c = ej_fastpath.run(fns, q, dq, u, p, k, opt, clock, rows, wants, steps, active)
            p = c.p
            if c.m:
                retries = 0
                max_cond, q, dq, u, k = max(max_cond, c.cond), c.q, c.dq, c.u, k + c.m - 1
                s_min, chunked = min(s_min, c.s_min), chunked + c.m
                continue
        out = fns.evaluate(q, dq, p)
        f0, fv, S, err = out.f0, out.fv, out.S, out.err
        if not (np.all(np.isfinite(f0)) and np.all(np.isfinite(fv)) and np.isfinite(S)):
            status = Status.DIVERGED
            message = divergence.message(t, dq, f0 + fv, opt.coordinates, _cond(fns, q, p))
            _keep_start(rows, t, q, dq, out.Tg, u, err)
            break
        if k % opt.cond_every == 0:
            E = fns.E_at(q, p)
            cond = linalg.cond(E)
            factor = None
            if switch is not None and switches < opt.max_switches:
                factor = switch.wanted(q, cond, E)
            if factor is not None and switch is not None:
                other = switch(q, factor)
                if other is not None:
                    fns, switches = other, switches + 1
                    p = fns.layout.retarget(p, switch.partitions[-1])
                    out = fns.evaluate(q, dq, p)
                    f0, fv = out.f0, out.fv
                    cond = linalg.cond(fns.E_at(q, p))
            max_cond = max(max_cond, cond)
            if not np.isfinite(cond) or cond > opt.cond_limit:
                status, message = Status.DIVERGED, f"cond(E) = {cond:.3g} at t = {t:.3f} s"
                break
        # Escape: tangential push while active.
        ext = np.zeros(n)
        if t < escape_until and escape_dir is not None:
            gain = opt.escape_gain * (1.0 + opt.gains[0] * err)  # outweighs the attraction
            ext = _escape_push(escape_dir, q, dq, pfaffian, winv, gain)
        d = decide(out, dq, u, k == 0, ext, opt)
        ahead: tuple[Array, Array] | None = None
        if active is not None and k < steps and err >= opt.stop_error:
            # the step (not the sample that ends the run) must keep off the obstacles left out
            ahead = fns.advance(q, dq, d.u, d.s, ext, p, dt)
            if active.first_unsafe(np.vstack([q, ahead[0]])) < 2:
                retries += 1
                if retries > active.count:
                    raise active.stuck()
                p = active.choose(p, np.vstack([q, ahead[0]]))
                k -= 1  # the same sample again with the new choice
                continue
            retries = 0
        u, s = d.u, d.s
        if not d.feasible:
            infeasible_samples += 1
            infeasible_first = t if infeasible_first is None else infeasible_first
        s_min = min(s_min, s) if S > 0.0 else s_min
        ddq, tau = d.ddq, d.tau
        if divergence.insane(dq, ddq)[0]:
            status = Status.DIVERGED
            message = divergence.message(t, dq, ddq, opt.coordinates, _cond(fns, q, p))
            _keep_start(rows, t, q, dq, out.Tg, u, err)
            break
        rows.add_one(t, q, dq, ddq, tau, u, s, err, np.concatenate([out.Tm @ dq, out.Tg]))
        if err < opt.stop_error:
            status, message = Status.REACHED, f"goal reached at t = {t:.3f} s"
            break
        # After an escape the generator gets a full window before the next stall verdict.
        due = k >= window and t >= escape_until + (opt.stall_window if escapes else 0.0)
        if due and opt.stalled(float(rows.error(k - window, k - window + 1)[0]), err):
            if opt.escape and S > 0.0 and escapes < opt.max_escapes:
                escape_dir = _escape_direction(out.gK, q, p_f)
                if escape_dir is not None and escapes % 2 == 1:
                    escape_dir = -escape_dir  # every other attempt goes the other way round
                escape_until, escapes = t + opt.escape_time, escapes + 1
                escape_left = opt.max_escapes - escapes
            else:
                status = Status.STALLED
                message = (
                    f"no progress over {opt.stall_window} s at t = {t:.3f} s, error {err:.4g} m"
                )
                break
        if k == steps:
            break
        q, dq = fns.advance(q, dq, u, s, ext, p, dt) if ahead is None else ahead
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(dq))):
            status = Status.DIVERGED
            message = divergence.message(t + dt, dq, ddq, opt.coordinates, None)
            break
    info = {
        "max_cond_E": max_cond,
        "escapes": escapes,
        "escapes_left": escape_left,
        "partition_switches": switches,
        "min_perturbation_scale": s_min,
        "chunked_samples": chunked,
    }
    if active is not None:
        info["slot_choices"] = active.choices
    return finish(rows, status, message, infeasible_samples, infeasible_first, info, opt)


def finish(
    rows: SampleLog,
    status: Status,
    message: str,
    infeasible_samples: int,
    infeasible_first: float | None,
    info: dict[str, Any],
    opt: RolloutOptions,
) -> RolloutResult:
    """Arrays, the torque-limit verdict and the message of a finished rollout.

    Any sample whose efforts leave the true limits (not only the safety zone) makes the run
    ``infeasible`` (eq. (30) violated), even when the goal was reached.
    """
    if not len(rows):
        raise RuntimeError("rollout produced no sample")  # cannot happen: k = 0 is recorded
    arr = rows.arrays()
    if status is Status.DIVERGED:  # drop the blow-up (divergence.onset)
        keep = divergence.onset(arr["ddq"], len(arr["t"]))
        arr = {key: value[:keep] for key, value in arr.items()}
        message += f" ({len(rows) - keep} samples before it)" if keep < len(rows) else ""
    over = np.zeros(len(arr["t"]))
    if opt.torque_control:
        t_lo, t_hi = opt.limits
        with np.errstate(invalid="ignore"):
            over = np.nanmax(
                np.maximum(np.maximum(arr["tau"] - t_hi, t_lo - arr["tau"]), 0.0), axis=1
            )
    broken = np.flatnonzero(over > 1e-9)
    outcome: tuple[Status, str] | None = None
    if broken.size:
        outcome = (status, message)
        verdict = (
            f"torque limits broken on {broken.size} samples ({broken.size * opt.dt:.3f} s) from "
            f"t = {arr['t'][broken[0]]:.3f} s, by up to {over.max():.3g} N m (eq. (30) violated)"
        )
        if status is Status.DIVERGED:  # the cause comes first
            message += "; " + verdict
        else:
            status, message = Status.INFEASIBLE, verdict + "; " + message
    elif infeasible_samples:
        message += (
            f"; safety zone left on {infeasible_samples} samples "
            f"({infeasible_samples * opt.dt:.3f} s) from t = {infeasible_first:.3f} s, limits kept"
        )
    info = {
        **info,
        "infeasible_samples": infeasible_samples,
        "max_torque_violation": float(over.max()) if over.size else 0.0,
    }
    return RolloutResult(
        status,
        message,
        arr["t"],
        arr["q"],
        arr["dq"],
        arr["ddq"],
        arr["tau"],
        arr["u"],
        arr["s"],
        arr["err"],
        info,
        arr.get("effort"),
        outcome=outcome,
    )


def _escape_direction(grad_K: Array, q: Array, p_f: Array) -> Array | None:
    """Unit tangent of the obstacle boundary in the platform plane, on the goal's side."""
    normal = -grad_K[:2]
    norm = float(np.linalg.norm(normal))
    if norm < 1e-12:
        return None
    normal = normal / norm
    tangent = np.array([-normal[1], normal[0]])
    return tangent if float(tangent @ (p_f[:2] - q[:2])) >= 0.0 else -tangent


def _escape_push(
    tangent: Array, q: Array, dq: Array, pfaffian: Any, winv: Array, gain: float
) -> Array:
    """Push along ``tangent``, projected into ker A (wheel metric), (n,).

    A (2,0) platform cannot accelerate sideways, so the platform is also turned towards the
    tangent (forwards or backwards, whichever is nearer) by a damped turn
    gain (2 turn - 1.5 dtheta/dt), re-evaluated every step while the escape lasts.
    """
    push = np.zeros(len(q))
    push[:2] = gain * tangent
    turn = float(np.arctan2(tangent[1], tangent[0]) - q[2])
    turn = (turn + np.pi / 2) % np.pi - np.pi / 2  # nearer of forwards / backwards
    push[2] = gain * (2.0 * turn - 1.5 * dq[2])
    return _projector(np.asarray(pfaffian(q), dtype=float), winv) @ push
