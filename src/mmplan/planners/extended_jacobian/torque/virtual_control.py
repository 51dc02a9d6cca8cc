r"""Virtual control: scaling the generator so that actuator efforts stay inside their limits.

Implements [PajakPajak] s.4 (eqs. (23)-(31)) and [Pajak] s.4 (eqs. (17)-(22)): the efforts
are affine in the virtual control, tau(u) = a u + b ([PajakPajak] eq. (24)), with
u in [0, 1]. The safety zone ([PajakPajak] eq. (25), [Pajak] eq. (19)) narrows the limits by
0.5 eps_tau (tau_max - tau_min) on each side (an infinite limit stays infinite).

When the nominal u (grown from the previous value by the growth law) drives some control
outside the zone, each control i with a_i != 0 bounds u ([PajakPajak] cases (a)-(d)):
(a) a_i > 0 and upper limit: u <= (tau_max - b_i)/a_i; (b) a_i < 0 and lower limit:
u <= (tau_min - b_i)/a_i; (c) a_i < 0 and upper limit: u >= (tau_max - b_i)/a_i;
(d) a_i > 0 and lower limit: u >= (tau_min - b_i)/a_i. The upper bounds give
u_max = min(...) (eq. (28)), the lower ones u_min = max(...) (eq. (29)); a solution exists iff
u_min <= u_max (eq. (30)). We take every control into account (not only those that left the
zone), so the chosen u cannot push another control out, and choose, among the feasible u,
the one nearest the nominal value (our reading of "choose u in
the intersection", see docs/extended_jacobian.md).
When eq. (30) is violated the sample is infeasible; we then use the u in [0, 1] with the
smallest largest violation and report it.

Growth laws (continuous increase of u back to 1 after scaling):
``constant`` du/dt = rho (1 - u) ([PajakPajak] eq. (31)); ``distance`` du/dt = (1 - u)/rho(t)
with rho(t) = rho_max - (rho_max - rho_min) exp(-|k(q) - p_f|) ([Pajak] eqs. (21)-(22),
read literally, see docs/extended_jacobian.md). Both are integrated exactly over a step with rho
held.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from mmplan.arrays import Array

_TINY = 1e-12


class Growth(StrEnum):
    """Growth law of the virtual control."""

    CONSTANT = "constant"
    DISTANCE = "distance"


def safety_zone(tau_min: Array, tau_max: Array, eps_tau: float) -> tuple[Array, Array]:
    """Narrowed limits tau_eps,min/max ([PajakPajak] eq. (25)); infinite limits stay infinite."""
    lo = np.asarray(tau_min, dtype=float).copy()
    hi = np.asarray(tau_max, dtype=float).copy()
    span = hi - lo
    finite = np.isfinite(span)
    lo[finite] += 0.5 * eps_tau * span[finite]
    hi[finite] -= 0.5 * eps_tau * span[finite]
    return lo, hi


def feasible_interval(a: Array, b: Array, lo: Array, hi: Array) -> tuple[float, float]:
    """[u_min, u_max] with lo <= a u + b <= hi, intersected with [0, 1]
    ([PajakPajak] eqs. (27)-(30)).

    Controls with a_i = 0 do not bound u; if such a control is outside [lo, hi] no u helps and
    the interval is returned empty (u_min > u_max).
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    pos, neg = a > _TINY, a < -_TINY
    idle = ~(pos | neg)
    if np.any(idle & ((b < lo - 1e-12) | (b > hi + 1e-12))):
        return 1.0, 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        upper_lim = (hi - b) / np.where(idle, 1.0, a)  # +-inf where hi is infinite
        lower_lim = (lo - b) / np.where(idle, 1.0, a)
    # (a) and (d) for a > 0; (b) and (c) for a < 0.
    u_max = min(
        1.0,
        float(np.min(upper_lim[pos], initial=np.inf)),
        float(np.min(lower_lim[neg], initial=np.inf)),
    )
    u_min = max(
        0.0,
        float(np.max(lower_lim[pos], initial=-np.inf)),
        float(np.max(upper_lim[neg], initial=-np.inf)),
    )
    return u_min, u_max


def max_violation(u: float, a: Array, b: Array, lo: Array, hi: Array) -> float:
    """Largest amount by which a u + b leaves [lo, hi] (0 inside)."""
    tau = a * u + b
    with np.errstate(invalid="ignore"):
        over = np.maximum(np.maximum(tau - hi, lo - tau), 0.0)
    return float(np.nanmax(over)) if over.size else 0.0


@dataclass(frozen=True)
class Choice:
    """Result of one virtual-control decision: u, whether it is feasible, and its violation."""

    u: float
    feasible: bool
    violation: float


def choose(u_nominal: float, a: Array, b: Array, lo: Array, hi: Array) -> Choice:
    """The virtual control for one sample ([PajakPajak] s.4).

    Args:
        u_nominal: u grown from the previous value by the growth law.
        a, b: Coefficients of tau(u) = a u + b (n_act,).
        lo, hi: Safety zone (n_act,).
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if max_violation(u_nominal, a, b, lo, hi) <= 0.0:
        return Choice(u_nominal, True, 0.0)
    u_min, u_max = feasible_interval(a, b, lo, hi)
    if u_min <= u_max:
        u = float(np.clip(u_nominal, u_min, u_max))
        return Choice(u, True, max_violation(u, a, b, lo, hi))
    # Eq. (30) violated: the largest violation max_k max(L_k(u), 0) is convex and piecewise
    # linear in u (lines L_k = tau_k - hi_k and lo_k - tau_k over the finite limits), so its
    # minimum over [0, 1] lies at an end, a zero of some L_k or an intersection of two L_k.
    fin_hi, fin_lo = np.isfinite(hi), np.isfinite(lo)
    slope = np.concatenate([a[fin_hi], -a[fin_lo]])
    const = np.concatenate([b[fin_hi] - hi[fin_hi], lo[fin_lo] - b[fin_lo]])
    with np.errstate(divide="ignore", invalid="ignore"):
        cross = (const[None, :] - const[:, None]) / (slope[:, None] - slope[None, :])
        zeros = -const / slope
    cands = np.concatenate([[0.0, 1.0, u_nominal], zeros, cross.ravel()])
    cands = np.clip(cands[np.isfinite(cands)], 0.0, 1.0)
    over = np.max(np.maximum(cands[:, None] * slope[None, :] + const[None, :], 0.0), axis=1)
    best = float(cands[int(np.argmin(over))])
    return Choice(best, False, max_violation(best, a, b, lo, hi))


def grow(
    u: float, dt: float, growth: Growth, rho: float, rho_min: float, rho_max: float, distance: float
) -> float:
    """u after dt under the growth law, integrated exactly with the rate held.

    ``constant``: du/dt = rho (1 - u) ([PajakPajak] eq. (31)).
    ``distance``: du/dt = (1 - u)/rho(t), rho(t) = rho_max - (rho_max - rho_min) exp(-distance)
    ([Pajak] eqs. (21)-(22)), ``distance`` = |k(q) - p_f| [m].
    """
    if growth is Growth.CONSTANT:
        rate = rho
    else:
        rate = 1.0 / (rho_max - (rho_max - rho_min) * np.exp(-distance))
    return float(1.0 - (1.0 - u) * np.exp(-rate * dt))
