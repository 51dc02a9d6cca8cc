"""Chunked fast path of the extended-Jacobian rollout (speed; same samples as the loop).

Without torque control (u = s = 1) and outside an escape push (ext = 0) nothing is decided
between steps except the stop tests, so ``chunk_steps`` steps run in one compiled call
(:func:`mmplan.planners.extended_jacobian.generator.GeneratorFunctions.run_chunk`); with torque
control in
feedback mode the choice of s and u runs inside the chunk too
(:mod:`~mmplan.planners.extended_jacobian.torque.feedback`). The
caller's loop (:func:`mmplan.planners.extended_jacobian.rollout.rollout`) keeps every other
decision:
:func:`run` accepts the samples before the first one at which the loop would do anything
else (NaN, goal reached, stall verdict, cond(E) above the switch threshold, an infeasible
virtual-control choice) and the loop handles that sample itself.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from mmplan import linalg
from mmplan.arrays import Array
from mmplan.planners.extended_jacobian import divergence
from mmplan.planners.extended_jacobian.active import ActiveSlots, CrowdedError
from mmplan.planners.extended_jacobian.generator import GeneratorFunctions
from mmplan.planners.extended_jacobian.options import RolloutOptions
from mmplan.planners.extended_jacobian.samples import SampleLog
from mmplan.planners.extended_jacobian.torque import feedback as ej_feedback


@dataclass(frozen=True)
class StallClock:
    """What the stall verdict of the loop needs: window [steps], escapes so far, escape end."""

    window: int
    escapes: int
    escape_until: float


def usable(fns: GeneratorFunctions, opt: RolloutOptions, k: int, steps: int, t_free: bool) -> bool:
    """True when samples k .. k + chunk_steps - 1 may run as one chunk.

    Args:
        t_free: No escape push acts at sample k (nor later, as time grows).
    """
    K = fns.chunk_steps
    feedback = opt.torque_control and fns.record is not None
    return (
        fns.chunk is not None
        and (feedback or not opt.torque_control)
        and opt.cond_every == K
        and k % K == 0
        and k + K <= steps
        and t_free
    )


@dataclass(frozen=True)
class Chunk:
    """Outcome of :func:`run`: accepted samples m, cond(E) at the first, the state at k + m,
    the virtual control u of the last accepted sample, the smallest perturbation scale and the
    parameters p (their slots chosen again when obstacles left out came near)."""

    m: int
    cond: float
    q: Array
    dq: Array
    u: float
    s_min: float
    p: Array


def run(
    fns: GeneratorFunctions,
    q: Array,
    dq: Array,
    u: float,
    p: Array,
    k: int,
    opt: RolloutOptions,
    clock: StallClock,
    rows: SampleLog,
    wants_switch: Callable[[Array, float, Array], bool] | None,
    steps: int,
    active: ActiveSlots | None = None,
) -> Chunk:
    """Run one chunk from sample k (virtual control u so far); append accepted samples to rows.

    ``wants_switch(q, cond(E), E)``: a partition switch is wanted at the chunk's start (the loop
    then decides that sample; None: no switch possible). ``steps``: the run's last sample (the
    next chunk is guessed only when it may run, :func:`usable`). ``active``: the scene has more
    obstacles than slots (:mod:`~mmplan.planners.extended_jacobian.active`): when a state of the
    chunk comes near an obstacle left out, the slots are chosen for the chunk's states and the
    chunk runs again (the chunks fall where they fall with every obstacle in a slot, so the
    samples are the same to the bit); when the chunk's states are near more obstacles of a type
    than slots, the chunk is cut before that state instead (the loop's samples from there equal
    the chunk's to rounding).
    """
    n, a, dt = fns.n, fns.n_act, opt.dt
    ahead = (steps - k) // fns.chunk_steps - 1  # later chunks that may run (guessed)

    def compute(p: Array) -> tuple[Array, ...]:
        """The chunk's states X (K, 2n), records R and u, s, ok per sample."""
        if opt.torque_control:
            chunk = ej_feedback.feedback_chunk(fns, opt)
            assert chunk is not None
            x0 = np.concatenate([q, dq, [u, 1.0 if k == 0 else 0.0]])
            XU, RU = (np.asarray(v).T for v in chunk(x0, np.concatenate([p, [dt]])))
            return XU[:, : 2 * n], RU, RU[:, n + a + 2], RU[:, n + a + 3], RU[:, -1]
        # the chunks after this one that may run start on a second core meanwhile
        X, R = fns.run_chunk(
            q, dq, 1.0, 1.0, np.zeros(n), p, dt, ahead=ahead, stop_error=opt.stop_error
        )
        ones = np.ones(len(R))
        return X, R, ones, ones, ones

    def accepted(X: Array, R: Array, ok: Array) -> int:
        """Samples before the first at which the loop must decide."""
        ddq, err, flag = R[:, :n], R[:, n + a], R[:, n + a + 1]
        kk = k + np.arange(len(err))
        event = ~np.isfinite(flag) | ~np.all(np.isfinite(X), axis=1) | (err < opt.stop_error)
        states_dq = np.vstack([dq[None, :], X[:-1, n:]])  # dq at each sample
        event |= divergence.insane(states_dq, ddq)  # the loop ends the run there
        event |= ok < 0.5
        history = rows.error(max(0, k - clock.window), k)
        older = np.concatenate([history, err])  # err at sample kk - window, where kk >= window
        idx = kk - clock.window - max(0, k - clock.window)
        wait = clock.escape_until + (opt.stall_window if clock.escapes else 0.0)
        due = (kk >= clock.window) & (kk * dt >= wait)
        prev = np.where(due, older[np.clip(idx, 0, len(older) - 1)], np.inf)
        with np.errstate(invalid="ignore"):
            event |= due & opt.stalled(prev, err)
        return int(np.argmax(event)) if event.any() else len(err)

    X, R, us, ss, ok = compute(p)
    m = accepted(X, R, ok)
    runs = 0
    while active is not None and m:  # states k .. k + m must keep off the obstacles left out
        path = np.vstack([q[None, :], X[:m, :n]])
        v = active.first_unsafe(path)
        if v > m:
            break
        runs += 1
        try:  # the slots chosen for the whole chunk, which runs again: the same schedule
            if runs > active.count:  # (a bound: the near set only grows run after run)
                raise active.stuck()
            p = active.choose(p, path)  # of chunks as with every obstacle in a slot
        except CrowdedError:  # cut: the loop takes the samples from there (to rounding)
            m = max(v - 1, 0)
            break
        X, R, us, ss, ok = compute(p)
        m = accepted(X, R, ok)
    ddq, tau, err = R[:, :n], R[:, n : n + a], R[:, n + a]
    t = (k + np.arange(len(err))) * dt
    none = Chunk(0, 0.0, q, dq, u, 1.0, p)
    if m == 0:
        return none
    E0 = fns.chunk_start_E() if not opt.torque_control else None
    if E0 is None:
        E0 = fns.E_at(q, p)
    cond = linalg.cond(E0)
    switching = wants_switch is not None and wants_switch(q, cond, E0)
    if not np.isfinite(cond) or cond > opt.cond_limit or switching:
        return none  # the loop decides at sample k
    states = np.vstack([np.concatenate([q, dq]), X[: m - 1]])
    effort = None if opt.torque_control else fns.chunk_effort()
    rows.add(
        t[:m],
        states[:, :n],
        states[:, n:],
        ddq[:m],
        tau[:m],
        us[:m],
        ss[:m],
        err[:m],
        None if effort is None else effort[:m],
    )
    x_m = X[m - 1]
    return Chunk(
        m, cond, x_m[:n].copy(), x_m[n:].copy(), float(us[m - 1]), float(ss[:m].min()), p
    )
