r"""Fused generator step and whole-chunk rollout of the extended-Jacobian planner (speed, SPEC 3).

``record_step(x, par) -> (x_next, rec)`` with x = [q; dq] and
par = [p (6); u; s; ext (n); dt] does in one call what a rollout step does in two
(:mod:`mmplan.planners.ej_dynamics`): the sample at (q, dq),
``rec = [ddq; tau; err; f]`` with ddq = f0 + ext + u fv + s (fp - S dq), tau = T0 + Tm ddq
(eqs. (16), (19), (22) of 000) and f = sum(f0) + sum(fv) + S (finite iff they are), and the
Strang-split RK4 step to x_next. The first RK4 stage reuses the sample's linear solve: v1 is
quadratic and the velocity part of v2 linear in dq, so with d1 = c dq, c = exp(-s S dt / 2),

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

from dataclasses import dataclass

import casadi as ca

#: Steps per ``chunk`` call (equal to the rollout's cond(E) check interval).
CHUNK = 25


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


def _rk4_strang(
    accel: ca.Function,
    damp: ca.Function,
    q: ca.SX,
    d1: ca.SX,
    k1a: ca.SX,
    u: ca.SX,
    s: ca.SX,
    ext: ca.SX,
    p: ca.SX,
    dt: ca.SX,
) -> tuple[ca.SX, ca.SX]:
    """RK4 stages 2-4 from the damped velocity d1 and the first-stage acceleration k1a, then
    the closing half of the Strang splitting (dq *= exp(-s S(q+) dt / 2); SPEC "Stiffness")."""
    k2v = d1 + dt / 2 * k1a
    k2a = accel(q + dt / 2 * d1, k2v, u, s, ext, p)
    k3v = d1 + dt / 2 * k2a
    k3a = accel(q + dt / 2 * k2v, k3v, u, s, ext, p)
    k4v = d1 + dt * k3a
    k4a = accel(q + dt * k3v, k4v, u, s, ext, p)
    q_next = q + dt / 6 * (d1 + 2 * k2v + 2 * k3v + k4v)
    dq_next = d1 + dt / 6 * (k1a + 2 * k2a + 2 * k3a + k4a)
    return q_next, dq_next * ca.exp(-s * damp(q_next) * dt / 2)


def build_record_step(
    parts: StepParts, accel: ca.Function, damp: ca.Function, cse: bool = False
) -> ca.Function:
    """``record_step`` (module docstring); ``accel``/``damp`` are the reference stage functions.

    Args:
        parts: Generator pieces at the sample state.
        accel: (q, dq, u, s, ext, p) -> f0 + u fv + s fp + P ext (stages 2-4).
        damp: q -> S (damping rate).
        cse: Merge common subexpressions (about 20 % fewer operations, ~1 s to find; worth
            it only for compiled code).
    """
    q, dq, p = parts.q, parts.dq, parts.p
    n = q.numel()
    x = ca.vertcat(q, dq)
    u, s, dt = ca.SX.sym("u"), ca.SX.sym("s"), ca.SX.sym("dt")
    ext = ca.SX.sym("ext", n)
    par = ca.vertcat(p, u, s, ext, dt)
    rhs = ca.solve(parts.E, ca.horzcat(parts.v1, parts.v2_dq, parts.v2_e))
    f0, fv_dq, fv_e = -rhs[:, 0], -rhs[:, 1], -rhs[:, 2]
    fv = fv_dq + fv_e
    ddq = f0 + ext + u * fv + s * (parts.fp - parts.S * dq)
    tau = parts.T0 + parts.Tm @ ddq
    flag = ca.sum1(f0) + ca.sum1(fv) + parts.S
    c = ca.exp(-s * parts.S * dt / 2)
    d1 = c * dq
    # first stage from the sample's own solve (v1 quadratic, v2's velocity part linear in dq)
    k1a = c * c * f0 + u * (c * fv_dq + fv_e) + s * parts.fp + parts.P @ ext
    q_next, dq_next = _rk4_strang(accel, damp, q, d1, k1a, u, s, ext, p, dt)
    outs = [ca.vertcat(q_next, dq_next), ca.vertcat(ddq, tau, parts.err, flag)]
    if cse:
        outs = ca.cse(outs)
    return ca.Function("mmplan_ej_record_step", [x, par], outs, ["x", "par"], ["x_next", "rec"])


def build_chunk(record_step: ca.Function, steps: int = CHUNK) -> ca.Function:
    """``chunk``: ``steps`` record steps with par held, in one call (mapaccum)."""
    x0 = ca.MX.sym("x0", record_step.size1_in(0))
    par = ca.MX.sym("par", record_step.size1_in(1))
    acc = record_step.mapaccum("mmplan_ej_chunk_acc", steps)
    X, REC = acc(x0, ca.repmat(par, 1, steps))
    return ca.Function("mmplan_ej_chunk", [x0, par], [X, REC], ["x0", "par"], ["X", "rec"])


def reference_step(
    accel: ca.Function, damp: ca.Function, n: int, p: ca.SX
) -> tuple[ca.Function, ca.Function]:
    """The reference step (q, dq, u, s, ext, p, dt) -> (q+, dq+) and its flat form.

    Strang splitting: dq *= exp(-s S dt / 2) before and after one RK4 step of
    ddq = accel (SPEC "Stiffness"); ``step_flat`` takes x = [q; dq; u; s; ext; p; dt].
    """
    u, sp, dt = ca.SX.sym("u"), ca.SX.sym("s"), ca.SX.sym("dt")
    ext = ca.SX.sym("ext", n)
    qs, dqs = ca.SX.sym("q", n), ca.SX.sym("dq", n)
    d1 = dqs * ca.exp(-sp * damp(qs) * dt / 2)
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
    xs = ca.SX.sym("x", 3 * n + 9)
    nxt = step(
        xs[:n],
        xs[n : 2 * n],
        xs[2 * n],
        xs[2 * n + 1],
        xs[2 * n + 2 : 3 * n + 2],
        xs[3 * n + 2 : 3 * n + 8],
        xs[3 * n + 8],
    )
    return step, ca.Function("mmplan_ej_step_flat", [xs], [ca.vertcat(*nxt)])


def step_wrapper(record: ca.Function, n: int) -> ca.Function:
    """``step_flat`` (x = [q; dq; u; s; ext; p; dt]) computed by the fused ``record_step``."""
    xs = ca.MX.sym("x", 3 * n + 9)
    par = ca.vertcat(xs[3 * n + 2 : 3 * n + 8], xs[2 * n : 3 * n + 2], xs[3 * n + 8])
    x_next, _ = record(xs[: 2 * n], par)
    return ca.Function("mmplan_ej_step_flat", [xs], [x_next])
