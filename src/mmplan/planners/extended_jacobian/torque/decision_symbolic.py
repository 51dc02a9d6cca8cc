r"""The feedback-mode decision of one sample as one CasADi function (online step, speed).

Symbolic twin of :func:`mmplan.planners.extended_jacobian.torque.decision.decide` for the online
step
(:mod:`mmplan.planners.extended_jacobian.online`): ``online(x) -> [ddq; tau; u; s; ok]`` with
x = [q; dq; u_prev; first; p], computing the generator terms and the choice of s and u by
cases (a)-(d) ([PajakPajak] eqs. (24)-(30),
:mod:`mmplan.planners.extended_jacobian.torque.virtual_control`) and the growth
law ([PajakPajak] eq. (31), [Pajak] eqs. (21)-(22)) in one call, so that a control loop pays one
function call a step. ``ok`` is 0 when a choice is infeasible (eq. (30) violated) or a
control with a_i = 0 is outside the zone; the caller then runs the NumPy decision, which
also picks the least-violating u. No escape push acts online (ext = 0).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import casadi as ca
import numpy as np

from mmplan.arrays import Array
from mmplan.planners.extended_jacobian.torque import virtual_control as vc

_TINY = 1e-12
_INF = float("inf")


def _violation(u: ca.SX, a: ca.SX, b: ca.SX, lo: Array, hi: Array) -> ca.SX:
    """Largest amount by which a u + b leaves [lo, hi] (0 inside), finite limits only."""
    worst = type(a)(0.0)
    for i in range(len(lo)):
        tau = a[i] * u + b[i]
        if np.isfinite(hi[i]):
            worst = ca.fmax(worst, tau - hi[i])
        if np.isfinite(lo[i]):
            worst = ca.fmax(worst, lo[i] - tau)
    return worst


def choose_sym(u_nominal: ca.SX, a: ca.SX, b: ca.SX, lo: Array, hi: Array) -> tuple[ca.SX, ca.SX]:
    """(u, ok): :func:`mmplan.planners.extended_jacobian.torque.virtual_control.choose` for the
    feasible cases.

    ok = 1 when u_nominal keeps the zone or the interval [u_min, u_max] of eqs. (28)-(29)
    is not empty (eq. (30)); u is then u_nominal clipped to it.
    """
    T = type(a)  # SX or MX
    u_max, u_min, idle_out = T(1.0), T(0.0), T(0.0)
    for i in range(len(lo)):
        pos, neg = a[i] > _TINY, a[i] < -_TINY
        idle = 1 - pos - neg
        safe = ca.if_else(idle, 1.0, a[i])
        if np.isfinite(hi[i]):
            up = (hi[i] - b[i]) / safe  # (a) for a > 0, (c) for a < 0
            u_max = ca.if_else(pos, ca.fmin(u_max, up), u_max)
            u_min = ca.if_else(neg, ca.fmax(u_min, up), u_min)
            idle_out = ca.fmax(idle_out, idle * (b[i] > hi[i] + 1e-12))
        if np.isfinite(lo[i]):
            down = (lo[i] - b[i]) / safe  # (d) for a > 0, (b) for a < 0
            u_min = ca.if_else(pos, ca.fmax(u_min, down), u_min)
            u_max = ca.if_else(neg, ca.fmin(u_max, down), u_max)
            idle_out = ca.fmax(idle_out, idle * (b[i] < lo[i] - 1e-12))
    inside = _violation(u_nominal, a, b, lo, hi) <= 0.0
    interval = (u_min <= u_max) * (1 - idle_out)
    u = ca.if_else(inside, u_nominal, ca.fmin(ca.fmax(u_nominal, u_min), u_max))
    return u, ca.fmax(inside, interval)


def build_online(
    terms: ca.Function,
    n: int,
    zone: tuple[Array, Array],
    dt: float,
    torque_control: bool,
    budget_perturbation: bool,
    growth: vc.Growth,
    rates: Sequence[float],
    cse: bool = False,
) -> ca.Function:
    """``online(x) -> [ddq; tau; u; s; ok]`` (module docstring).

    Args:
        terms: The generator's ``terms`` function (q, dq, p) -> (f0, fv, fp, S, T0, Tm, ...).
        n: Number of coordinates.
        zone: Safety zone (lo, hi) (n_act,). dt: Step between calls [s].
        torque_control: Virtual control on (else u = s = 1).
        budget_perturbation: Fit the obstacle push to the torque budget (s).
        growth, rates: Growth law and (rho, rho_min, rho_max).
        cse: Merge common subexpressions (for C code; changes no value).
    """
    # SX, or MX for a terms function made of calls (the culled obstacle terms)
    T: Any = ca.MX if terms.is_a("MXFunction") else ca.SX
    x: Any = T.sym("x", 2 * n + 2 + terms.size1_in(terms.n_in() - 1))
    q, dq, u_prev, first, p = x[:n], x[n : 2 * n], x[2 * n], x[2 * n + 1], x[2 * n + 2 :]
    f0, fv, fp, S, T0, Tm, err, _Tg, _gK = terms(q, dq, p)
    pert = fp - S * dq
    u, s, ok = T(1.0), T(1.0), T(1.0)
    if torque_control:
        lo, hi = (np.asarray(z, dtype=float) for z in zone)
        b_base = T0 + Tm @ f0
        if budget_perturbation:
            s_fit, ok_s = choose_sym(T(1.0), Tm @ pert, b_base, lo, hi)
            s = ca.if_else(S > 0.0, s_fit, 1.0)
            ok = ca.if_else(S > 0.0, ok_s, 1.0)
        b = b_base + s * (Tm @ pert)
        rho, rho_min, rho_max = rates
        if growth is vc.Growth.CONSTANT:
            rate = T(rho)
        else:
            rate = 1.0 / (rho_max - (rho_max - rho_min) * ca.exp(-err))
        u_nom = ca.if_else(first, 0.0, 1.0 - (1.0 - u_prev) * ca.exp(-rate * dt))
        u, ok_u = choose_sym(u_nom, Tm @ fv, b, lo, hi)
        ok = ok * ok_u
    ddq = f0 + u * fv + s * pert
    out = ca.vertcat(ddq, T0 + Tm @ ddq, u, s, ok)
    return ca.Function("mmplan_ej_online", [x], [ca.densify(ca.cse(out) if cse else out)])
