"""One sample's decision of the extended-Jacobian generator under torque limits (feedback mode).

Shared by the planned rollout (:mod:`mmplan.planners.extended_jacobian.rollout`) and the online step
(:mod:`mmplan.planners.extended_jacobian.online`): perturbation budget s, virtual control u
(cases (a)-(d) and growth laws of :mod:`mmplan.planners.extended_jacobian.torque.virtual_control`,
[PajakPajak] eqs. (24)-(31)), then ddq = f0 + ext + u fv + s (fp - S dq) and
tau = T0 + Tm ddq ([PajakPajak] eq. (22)).
"""

from __future__ import annotations

from dataclasses import dataclass

from mmplan.arrays import Array
from mmplan.planners.extended_jacobian.functions import Terms
from mmplan.planners.extended_jacobian.options import RolloutOptions
from mmplan.planners.extended_jacobian.torque import virtual_control as vc


@dataclass(frozen=True)
class Decision:
    """One sample's choice: acceleration (n,), efforts (n_act,), u, s and eq. (30) feasibility."""

    ddq: Array
    tau: Array
    u: float
    s: float
    feasible: bool


def decide(
    out: Terms, dq: Array, u_prev: float, first: bool, ext: Array, opt: RolloutOptions
) -> Decision:
    """Perturbation budget s, virtual control u, ddq and tau at one state (module docstring).

    Args:
        out: Generator terms at the state.
        dq: Velocity (n,). u_prev: Previous u. first: True at t = 0 (u0 = 0).
        ext: Extra (escape) acceleration, already in ker A (n,).
        opt: Options (torque control, zone, growth law).
    """
    f0, fv, fp, S, T0, Tm = out.f0, out.fv, out.fp, out.S, out.T0, out.Tm
    base_acc = f0 + ext
    pert = fp - S * dq  # obstacle push and damping, eq. (19)
    u, s, feasible = 1.0, 1.0, True
    if opt.torque_control:
        lo, hi = opt.zone
        b_base = T0 + Tm @ base_acc
        if opt.budget_perturbation and S > 0.0:
            s = vc.choose(1.0, Tm @ pert, b_base, lo, hi).u
        b = b_base + s * (Tm @ pert)
        err = out.err
        u_nom = (
            0.0
            if first
            else vc.grow(u_prev, opt.dt, opt.eps_growth, opt.rho, opt.rho_min, opt.rho_max, err)
        )
        pick = vc.choose(u_nom, Tm @ fv, b, lo, hi)
        u, feasible = pick.u, pick.feasible
    ddq = base_acc + u * fv + s * pert
    return Decision(ddq, T0 + Tm @ ddq, u, s, feasible)
