r"""Fused generator step and whole-chunk rollout of the extended-Jacobian planner (speed).

``record_step(x, par) -> (x_next, rec)`` with x = [q; dq] and
par = [p; u; s; ext (n); dt] (p the generator parameters,
:mod:`~mmplan.planners.extended_jacobian.parameters`) does in one call what a rollout step
does in two
(:mod:`mmplan.planners.extended_jacobian.generator`): the sample at (q, dq),
``rec = [ddq; tau; err; f]`` with ddq = f0 + ext + u fv + s (fp - S dq), tau = T0 + Tm ddq
([PajakPajak] eqs. (16), (19), (22)) and f = sum(f0) + sum(fv) + S (finite iff they are), and the
Strang-split RK4 step to x_next, whose velocity is projected into ker A(q+) with the
wheel-metric projector P (constraint stabilization: A dq = 0 to rounding at every sample,
where the explicit step alone leaves a residual growing as dt^4 that Lambda_II only damps:
measured on youbot3r-obstacles 4.5e-7 at dt = 10 ms, 7.6e-6 at 20 ms, against the checker's
1e-6; T(1 cm) / T(1 mm) at dt = 2 ms unchanged, 9.332 / 11.724 s). The first RK4 stage
reuses the sample's linear solve: v1 is quadratic and the velocity part of v2 linear in dq,
so with d1 = c dq, c = exp(-s S dt / 2),

.. math::

    f_0(q, d_1) = c^2 f_0(q, \dot q),\quad
    f_v(q, d_1) = c\, f_{v,\dot q}(q, \dot q) + f_{v,e}(q),

where f_v = -E^{-1}[\Lambda_V \dot e_I; \Lambda_{II} e_{II}] - E^{-1}[\Lambda_P e_I; 0] is
split into its velocity and error parts; four generator evaluations a step instead of five.
For C code common subexpressions are merged (``ca.cse``), which changes no value.

``chunk(x0, par) -> (X, REC)``: ``CHUNK`` such steps with par held, one call
(``Function.mapaccum``), columns j = state after step j and record at its start.
:func:`reference_step` is the plain step (five generator evaluations) the fused one is
tested against.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import casadi as ca

#: Steps per ``chunk`` call (equal to the rollout's cond(E) check interval).
CHUNK = 50


@dataclass(frozen=True)
class StepParts:
    """Symbolic pieces of the generator at one state (all SX in q, dq, p)."""

    q: ca.SX
    dq: ca.SX
    p: ca.SX
    E: ca.SX
    v1: ca.SX
    v2_dq: ca.SX  # velocity part of v2
    v2_e: ca.SX  # error part of v2
    fp: ca.SX
    S: ca.SX
    P: ca.SX
    T0: ca.SX
    Tm: ca.SX
    err: ca.SX
    solve: Callable[[ca.SX, ca.SX], ca.SX] = ca.solve  # E^-1 B (structure.structured_solve)


def _rk4_strang(
    accel: Callable[..., Any],
    damp: Callable[[Any, Any], Any],
    q: Any,
    d1: Any,
    k1a: Any,
    u: Any,
    s: Any,
    ext: Any,
    p: Any,
    dt: Any,
) -> tuple[Any, Any]:
    """RK4 stages 2-4 from the damped velocity d1 and the first-stage acceleration k1a, then
    the closing half of the Strang splitting (dq *= exp(-s S(q+) dt / 2): the stiff damping
    term exactly, see docs/extended_jacobian.md)
    and the projection of dq into ker A(q+) (module docstring)."""
    k2v = d1 + dt / 2 * k1a
    k2a = accel(q + dt / 2 * d1, k2v, u, s, ext, p)
    k3v = d1 + dt / 2 * k2a
    k3a = accel(q + dt / 2 * k2v, k3v, u, s, ext, p)
    k4v = d1 + dt * k3a
    k4a = accel(q + dt * k3v, k4v, u, s, ext, p)
    q_next = q + dt / 6 * (d1 + 2 * k2v + 2 * k3v + k4v)
    dq_next = d1 + dt / 6 * (k1a + 2 * k2a + 2 * k3a + k4a)
    S1, P1 = damp(q_next, p)
    return q_next, P1 @ (dq_next * ca.exp(-s * S1 * dt / 2))


def build_record_step(
    parts: StepParts, accel: ca.Function, damp: ca.Function, cse: bool = False
) -> ca.Function:
    """``record_step`` (module docstring); ``accel``/``damp`` are the reference stage functions.

    Args:
        parts: Generator pieces at the sample state.
        accel: (q, dq, u, s, ext, p) -> f0 + u fv + s fp + P ext (stages 2-4).
        damp: (q, p) -> (S, P) (damping rate, wheel-metric projector into ker A).
        cse: Merge common subexpressions (about 20 % fewer operations, ~1 s to find; worth
            it only for compiled code).
    """
    h = _head(parts)
    u, s, ext, dt = h.u, h.s, h.ext, h.dt
    q_next, dq_next = _rk4_strang(accel, damp, parts.q, h.d1, h.k1a, u, s, ext, parts.p, dt)
    outs = [ca.vertcat(q_next, dq_next), h.rec]
    if cse:
        outs = ca.cse(outs)
    return ca.Function("mmplan_ej_record_step", [h.x, h.par], outs, ["x", "par"], ["x_next", "rec"])


@dataclass(frozen=True)
class _Head:
    """Symbols and sample part of ``record_step``: the record and the first RK4 stage."""

    x: ca.SX
    par: ca.SX
    u: ca.SX
    s: ca.SX
    ext: ca.SX
    dt: ca.SX
    d1: ca.SX
    k1a: ca.SX
    rec: ca.SX


def _head(parts: StepParts) -> _Head:
    """The sample's record and the damped velocity / first-stage acceleration (docstring)."""
    q, dq, p = parts.q, parts.dq, parts.p
    n = q.numel()
    u, s, dt = ca.SX.sym("u"), ca.SX.sym("s"), ca.SX.sym("dt")
    ext = ca.SX.sym("ext", n)
    rhs = parts.solve(parts.E, ca.horzcat(parts.v1, parts.v2_dq, parts.v2_e))
    f0, fv_dq, fv_e = -rhs[:, 0], -rhs[:, 1], -rhs[:, 2]
    fv = fv_dq + fv_e
    ddq = f0 + ext + u * fv + s * (parts.fp - parts.S * dq)
    tau = parts.T0 + parts.Tm @ ddq
    flag = ca.sum1(f0) + ca.sum1(fv) + parts.S
    c = ca.exp(-s * parts.S * dt / 2)
    # first stage from the sample's own solve (v1 quadratic, v2's velocity part linear in dq)
    k1a = c * c * f0 + u * (c * fv_dq + fv_e) + s * parts.fp + parts.P @ ext
    rec = ca.vertcat(ddq, tau, parts.err, flag)
    return _Head(ca.vertcat(q, dq), ca.vertcat(p, u, s, ext, dt), u, s, ext, dt, c * dq, k1a, rec)


def build_record_step_culled(
    parts: StepParts,
    S_sym: ca.SX,
    fp_sym: ca.SX,
    accel: ca.Function,
    obstacle_terms: ca.Function,
    obstacle_damping: ca.Function,
    projector: ca.Function,
) -> ca.Function:
    """``record_step`` with the obstacle terms as culled calls
    (:mod:`~mmplan.planners.extended_jacobian.obstacles`).

    The sample part and the stage accelerations are SX functions (common subexpressions
    merged) of the state and of the obstacle terms (S, fp) that ``obstacle_terms`` returns
    (it skips obstacles no collision point is near); the composition is MX. Same values as
    :func:`build_record_step` to rounding.

    Args:
        parts: Generator pieces with ``parts.S`` and ``parts.fp`` the symbols S_sym, fp_sym.
        S_sym, fp_sym: Symbols of the damping rate (1) and the push as applied (n).
        accel: (q, dq, u, s, ext, p, fp) -> f0 + u fv + s fp + P ext.
        obstacle_terms: (q, p) -> (S, fp, ...). obstacle_damping: (q, p) -> S. projector: q -> P.
    """
    n = parts.q.numel()
    h = _head(parts)
    head = ca.Function("mmplan_ej_head", [h.x, h.par, S_sym, fp_sym], ca.cse([h.d1, h.k1a, h.rec]))
    xm, pm = ca.MX.sym("x", 2 * n), ca.MX.sym("par", h.par.numel())
    k = parts.p.numel()
    q, p, u, s, ext, dt = xm[:n], pm[:k], pm[k], pm[k + 1], pm[k + 2 : k + 2 + n], pm[k + 2 + n]
    S0, fp0 = obstacle_terms(q, p)[:2]
    d1, k1a, rec = head(xm, pm, S0, fp0)

    def stage(qs: ca.MX, vs: ca.MX, u: ca.MX, s: ca.MX, ext: ca.MX, p: ca.MX) -> ca.MX:
        return accel(qs, vs, u, s, ext, p, obstacle_terms(qs, p)[1])

    def damp(qs: ca.MX, p: ca.MX) -> tuple[ca.MX, ca.MX]:
        return obstacle_damping(qs, p), projector(qs)

    q_next, dq_next = _rk4_strang(stage, damp, q, d1, k1a, u, s, ext, p, dt)
    return ca.Function(
        "mmplan_ej_record_step",
        [xm, pm],
        [ca.vertcat(q_next, dq_next), rec],
        ["x", "par"],
        ["x_next", "rec"],
    )


def build_chunk(record_step: ca.Function, steps: int = CHUNK) -> ca.Function:
    """``chunk``: ``steps`` record steps with par held, in one call (mapaccum)."""
    x0 = ca.MX.sym("x0", record_step.size1_in(0))
    par = ca.MX.sym("par", record_step.size1_in(1))
    acc = record_step.mapaccum("mmplan_ej_chunk_acc", steps)
    X, REC = acc(x0, ca.repmat(par, 1, steps))
    return ca.Function("mmplan_ej_chunk", [x0, par], [X, REC], ["x0", "par"], ["X", "rec"])


def build_chunk_flat(chunk: ca.Function, E: ca.Function, effort: ca.Function) -> ca.Function:
    """``chunk_flat([x0; par]) -> [vec(X); vec(REC); vec(E(q0)); vec(EFF)]``: ``chunk`` with
    one dense input and output (called through ctypes, ``codegen.NativeFunction``; vec stacks
    the columns, one step each), E at the first state for the caller's cond(E) check, and
    EFF = ``effort`` ([Tm dq; Tg], the time-scaling coefficients) at each step's start."""
    nx, npar = chunk.size1_in(0), chunk.size1_in(1)
    xp = ca.MX.sym("xp", nx + npar)
    x0, par = xp[:nx], xp[nx:]
    X, REC = chunk(x0, par)
    n = nx // 2
    E0 = E(x0[:n], par[: E.size1_in(1)])
    K = X.shape[1]
    starts = ca.horzcat(x0, X[:, : K - 1])
    eff = effort.map(K)(starts)
    out = ca.vertcat(*(ca.vec(ca.densify(v)) for v in (X, REC, E0, eff)))
    return ca.Function("mmplan_ej_chunk_flat", [xp], [out])


def build_ee_flat(q: ca.SX, ee: ca.SX, steps: int = CHUNK) -> ca.Function:
    """``ee_flat([q_1; ...; q_K]) -> [k(q_1); ...; k(q_K)]``: the end-effector position at
    ``steps`` states in one call (the trajectory's ``ee`` column, called through ctypes)."""
    fn = ca.Function("mmplan_ej_ee", [q], [ee]).map(steps)
    n = q.numel()
    Q = ca.MX.sym("Q", n * steps)
    return ca.Function("mmplan_ej_ee_flat", [Q], [ca.vec(fn(ca.reshape(Q, n, steps)))])


def reference_step(
    accel: ca.Function, damp: ca.Function, n: int, p: ca.SX
) -> tuple[ca.Function, ca.Function]:
    """The reference step (q, dq, u, s, ext, p, dt) -> (q+, dq+) and its flat form.

    Strang splitting: dq *= exp(-s S dt / 2) before and after one RK4 step of
    ddq = accel (the stiff damping term exactly, docs/extended_jacobian.md), then dq projected into
    ker A(q+); ``step_flat`` takes x = [q; dq; u; s; ext; p; dt].
    """
    k = p.numel()
    u, sp, dt = ca.SX.sym("u"), ca.SX.sym("s"), ca.SX.sym("dt")
    ext = ca.SX.sym("ext", n)
    qs, dqs = ca.SX.sym("q", n), ca.SX.sym("dq", n)
    d1 = dqs * ca.exp(-sp * damp(qs, p)[0] * dt / 2)
    k1a = accel(qs, d1, u, sp, ext, p)
    q_next, dq_next = _rk4_strang(accel, damp, qs, d1, k1a, u, sp, ext, p, dt)
    step = ca.Function(
        "mmplan_ej_step",
        [qs, dqs, u, sp, ext, p, dt],
        [q_next, dq_next],
        ["q", "dq", "u", "s", "ext", "p", "dt"],
        ["q_next", "dq_next"],
    )
    step = step.expand()
    xs = ca.SX.sym("x", 3 * n + 3 + k)
    nxt = step(
        xs[:n],
        xs[n : 2 * n],
        xs[2 * n],
        xs[2 * n + 1],
        xs[2 * n + 2 : 3 * n + 2],
        xs[3 * n + 2 : 3 * n + 2 + k],
        xs[3 * n + 2 + k],
    )
    return step, ca.Function("mmplan_ej_step_flat", [xs], [ca.vertcat(*nxt)])


def step_wrapper(record: ca.Function, n: int, k: int) -> ca.Function:
    """``step_flat`` (x = [q; dq; u; s; ext; p (k); dt]) computed by the fused ``record_step``."""
    xs = ca.MX.sym("x", 3 * n + 3 + k)
    par = ca.vertcat(xs[3 * n + 2 : 3 * n + 2 + k], xs[2 * n : 3 * n + 2], xs[3 * n + 2 + k])
    x_next, _ = record(xs[: 2 * n], par)
    return ca.Function("mmplan_ej_step_flat", [xs], [x_next])
