r"""Does a trajectory describe one motion of the scenario's robot, from the scenario's start?

The checker judges a plan from physics and the scenario only; this module holds the checks
that tie the columns of a trajectory to each other and to the scenario, so that none of them
can be edited alone (docs/conventions.md, "What the checker verifies"):

* **start**: the first sample is at :math:`t_0 = 0` and :math:`q_0` equals the scenario's
  ``start`` within ``START_TOL`` (1e-9 rad or m; honest plans: exactly 0, the planners copy
  the start and trajectory.csv round-trips float64). Not for a segment task: the
  manipulability-area planner chooses its own base start (the scenario's ``start`` is unused,
  docs/manipulability_area.md); :math:`t_0 = 0` still holds.
* **columns**: a plan whose robot has torque limits carries one ``tau.<actuator>`` column per
  actuator, in the robot's order; so does every plan of a method in
  :data:`EFFORT_METHODS`, which also carries ``u`` (:data:`U_METHODS`). Efforts present are
  always named exactly as the robot's actuators. (Dropping the columns used to switch the
  checker silently to model efforts; now the limits are checked on the model efforts anyway,
  and a missing column is a failure of its own.)
* **tau vs model**: the efforts the motion needs are recomputed from the robot model,
  :math:`\tau = (N^T B)^{-1} N^T (M(q)\ddot q + c(q, \dot q))` ([PajakPajak] eq. (22)),
  from the q, dq, ddq columns; the torque limits are checked on them
  (:mod:`mmplan.verify.check`), and the ``tau`` columns must agree with them within
  ``TAU_MODEL_TOL`` (1e-6 N m or N). Honest plans of every built-in scenario agree to
  3.6e-15 N m (measured 2026-11-26; the extended-Jacobian planner evaluates the same
  dynamics, split as :math:`T_0 + T_m\ddot q`). A robot with joint friction is no exception:
  :math:`c(q, \dot q)` includes the robot's own friction (viscous plus smoothed Coulomb,
  docs/conventions.md "Dynamics"), so written efforts must include it too.
* **ddq vs the interpolant**: between samples the motion is the cubic Hermite interpolant
  through :math:`(t_k, q_k, \dot q_k)` (:mod:`mmplan.interpolant`); its acceleration is linear
  on each step (:math:`a_k` at the start, :math:`b_k` at the end) and may jump at a sample.
  The ``ddq`` column at sample :math:`k` must lie in the range of the interpolant's
  acceleration on the adjacent steps, :math:`[\min, \max]` of
  :math:`\{a_{k-1}, b_{k-1}, a_k, b_k\}`, widened by

  .. math::

      \delta_{kj} = \text{DDQ\_LOCAL\_TOL}\cdot W_{kj} + \text{DDQ\_REL\_TOL}\cdot S_j
          + \text{DDQ\_ABS\_TOL} + \rho_{kj},

  with :math:`W_{kj}` the spread (max - min) of the interpolant's acceleration on the four
  steps around the sample (:math:`k-2 \dots k+1`): how much the acceleration varies there, the
  most by which an honest one-sided or coarsely sampled ddq can miss the Hermite's range;
  :math:`S_j` the interpolant's peak :math:`|\ddot q_j|` over the whole plan (from q and dq,
  never from the ddq column); and :math:`\rho_{kj}` the rounding of :math:`a, b`
  (:math:`16\varepsilon(6|q|/h^2 + 6|\dot q|/h)` over the two samples of each adjacent step).
  Measured (2026-11-24) as the largest :math:`\text{excess} / (W + 0.02 S_j)` over the
  samples: honest plans of every built-in scenario <= 0.87 (youbot3r-obstacles, the time
  scaling's one-sided acceleration at its bang-bang switches), eight random youbot-3r
  scenes <= 0.21, their exports at 10, 30 and 100 Hz <= 1.51 (random-7 at 10 Hz); a ddq
  column scaled by 1.5 >= 4.8 (ur5-omni-table; 11-25 elsewhere), by 1.2 or 0.8 >= 1.9.
  Hence ``DDQ_LOCAL_TOL`` = 3 (twice the honest worst) and ``DDQ_REL_TOL`` = 0.02: a ddq column
  scaled by 1.5 with its efforts recomputed from the model fails this check on every
  built-in plan. The former allowance, 0.5 :math:`S_j` alone, let that scaling through
  (it moves the peak sample by exactly 0.5 :math:`S_j`).

The dq column is tied to q by the trapezoid rule (:mod:`mmplan.verify.check`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mmplan.arrays import Array
from mmplan.interpolant import step_accelerations
from mmplan.problem import Problem
from mmplan.task import DrawSegment
from mmplan.trajectory import Trajectory

START_TOL = 1e-9  # [rad or m] for q_0, [s] for t_0
TAU_MODEL_TOL = 1e-6  # [N m or N]
DDQ_LOCAL_TOL = 3.0  # of the spread of the interpolant's acceleration around the sample
DDQ_REL_TOL = 0.02  # of the coordinate's peak |ddq| on the interpolant
DDQ_ABS_TOL = 1e-6  # [rad/s^2 or m/s^2]
#: Methods whose plans always carry ``tau.*`` (their efforts), and those that carry ``u`` (the
#: virtual control, or the time rate w of the time-scaling mode). Other methods write neither
#: unless the robot has torque limits (then ``tau.*`` is required of every plan).
EFFORT_METHODS = frozenset({"extended-jacobian"})
U_METHODS = frozenset({"extended-jacobian"})

_EPS = float(np.finfo(float).eps)


@dataclass(frozen=True)
class Consistency:
    """The columns against each other and against the scenario (module doc).

    Attributes:
        start_time: t of the first sample (must be 0).
        start_deviation: max_i |q_0,i - start_i| (None for a segment task: any start).
        start_where: The coordinate of that deviation.
        columns: One line per missing or misnamed column (empty when complete).
        required: The columns the plan must carry, e.g. ``("tau.*", "u")``.
        tau_model_deviation: max |tau column - model efforts| (None without tau columns).
        tau_where: Actuator and time of that deviation.
        ddq_excess: The largest distance of the ddq column outside the interpolant's range
            on the adjacent steps, relative to its allowance (the sample that comes
            closest to, or goes furthest beyond, its allowance); 0 within the range.
        ddq_allowed: The allowance delta_kj at that sample.
        ddq_where: Coordinate and time of that sample, with the range.
    """

    start_time: float = 0.0
    start_deviation: float | None = 0.0
    start_where: str = ""
    columns: tuple[str, ...] = ()
    required: tuple[str, ...] = ()
    tau_model_deviation: float | None = None
    tau_where: str = ""
    ddq_excess: float = 0.0
    ddq_allowed: float = math.inf
    ddq_where: str = ""

    def failures(self) -> list[str]:
        """One line per failed check, naming value, threshold and where."""
        out: list[str] = []
        if not abs(self.start_time) <= START_TOL:
            out.append(f"start: the trajectory begins at t = {self.start_time:.6g} s, not at 0")
        if self.start_deviation is not None and not self.start_deviation <= START_TOL:
            out.append(f"start: q at the first sample differs from the scenario's start by "
                       f"{self.start_deviation:.3g} ({self.start_where}; > {START_TOL:g})")
        out += [f"columns: {line}" for line in self.columns]
        if self.tau_model_deviation is not None and not self.tau_model_deviation <= TAU_MODEL_TOL:
            out.append(f"tau vs model: the tau columns differ from the model efforts "
                       f"(N^T B)^-1 N^T (M ddq + c) of q, dq, ddq by "
                       f"{self.tau_model_deviation:.3g} (> {TAU_MODEL_TOL:g} N m or N), "
                       f"{self.tau_where}")
        if not self.ddq_excess <= self.ddq_allowed:
            out.append(f"ddq consistency: the ddq column leaves the range of the interpolant's "
                       f"acceleration (cubic Hermite of q, dq) on the adjacent steps by "
                       f"{self.ddq_excess:.3g} (> allowed {self.ddq_allowed:.3g}), "
                       f"{self.ddq_where}")
        return out


def check_consistency(trajectory: Trajectory, problem: Problem,
                      tau_model: Array | None) -> Consistency:
    """The consistency checks of ``trajectory`` against ``problem`` (module doc).

    Args:
        trajectory: The trajectory (its coordinates already match the robot's).
        problem: The problem it claims to solve.
        tau_model: Model efforts (N, n_act) of the q, dq, ddq columns, or None when the
            robot has no actuators.
    """
    tr, robot = trajectory, problem.robot
    t = np.asarray(tr.t, dtype=float)
    q, dq, ddq = (np.asarray(a, dtype=float) for a in (tr.q, tr.dq, tr.ddq))
    start_dev, start_where = None, ""
    if not isinstance(problem.task, DrawSegment):
        diff = np.abs(q[0] - np.asarray(problem.start, dtype=float))
        i = int(np.argmax(np.where(np.isnan(diff), np.inf, diff)))
        start_dev, start_where = float(diff[i]), robot.coordinates[i]
    columns, required = _columns(tr, problem)
    tau_dev, tau_where = None, ""
    if tr.tau is not None and tr.actuators == robot.actuators and tau_model is not None:
        gap = np.abs(np.asarray(tr.tau, dtype=float) - tau_model)
        if gap.size:
            k, j = (int(v) for v in np.unravel_index(
                int(np.argmax(np.where(np.isnan(gap), np.inf, gap))), gap.shape))
            tau_dev = float(gap[k, j])
            tau_where = (f"{robot.actuators[j]} at t = {t[k]:.4g} s (tau {tr.tau[k, j]:.4g}, "
                         f"model {tau_model[k, j]:.4g})")
    excess, allowed, ddq_where = _ddq_against_interpolant(t, q, dq, ddq, robot.coordinates)
    return Consistency(start_time=float(t[0]), start_deviation=start_dev,
                       start_where=start_where, columns=tuple(columns), required=required,
                       tau_model_deviation=tau_dev, tau_where=tau_where, ddq_excess=excess,
                       ddq_allowed=allowed, ddq_where=ddq_where)


def _columns(tr: Trajectory, problem: Problem) -> tuple[list[str], tuple[str, ...]]:
    """Missing or misnamed columns (one line each) and the columns required."""
    robot = problem.robot
    method = str(getattr(problem.settings, "method", ""))
    limited = robot.limits.has_torque_limits
    need_tau = limited or method in EFFORT_METHODS
    need_u = method in U_METHODS
    required = (*(("tau.*",) if need_tau else ()), *(("u",) if need_u else ()))
    out: list[str] = []
    expected = ", ".join(f"tau.{a}" for a in robot.actuators)
    if tr.tau is not None and tr.actuators != robot.actuators:
        out.append(f"effort columns {', '.join(f'tau.{a}' for a in tr.actuators) or '(none)'} "
                   f"do not name the robot's actuators: expected {expected}")
    elif tr.tau is None and need_tau:
        why = ("the robot has torque limits" if limited
               else f"method {method} writes its efforts")
        out.append(f"effort columns missing ({why}): expected {expected}")
    if tr.u is None and need_u:
        out.append(f"column u missing (method {method} writes its virtual control or time "
                   f"rate there)")
    return out, required


def _ddq_against_interpolant(t: Array, q: Array, dq: Array, ddq: Array,
                             names: tuple[str, ...]) -> tuple[float, float, str]:
    """(excess, allowance, where) at the sample whose ddq goes furthest beyond its allowance
    relative to it; (0, inf, "") for one sample or non-finite values (reported elsewhere)."""
    N = len(t)
    if N < 2 or not (np.isfinite(t).all() and np.isfinite(q).all() and np.isfinite(dq).all()
                     and np.isfinite(ddq).all()):
        return 0.0, math.inf, ""
    a, b = step_accelerations(t, q, dq)  # (N - 1, n) each
    h = np.diff(t)[:, None]
    rounding = 16.0 * _EPS * (6.0 * (np.abs(q[:-1]) + np.abs(q[1:])) / h**2
                              + 6.0 * (np.abs(dq[:-1]) + np.abs(dq[1:])) / h)
    lo, hi = np.full_like(q, np.inf), np.full_like(q, -np.inf)
    wide_lo, wide_hi = lo.copy(), hi.copy()
    slack = np.zeros_like(q)
    low, high = np.minimum(a, b), np.maximum(a, b)  # (N - 1, n) per step
    samples = np.arange(N)
    for offset in (-2, -1, 0, 1):  # step k + offset: the four steps around sample k
        step = samples + offset
        ok = (step >= 0) & (step < N - 1)
        wide_lo[ok] = np.minimum(wide_lo[ok], low[step[ok]])
        wide_hi[ok] = np.maximum(wide_hi[ok], high[step[ok]])
        if offset in (-1, 0):  # the step ending / starting at k
            lo[ok] = np.minimum(lo[ok], low[step[ok]])
            hi[ok] = np.maximum(hi[ok], high[step[ok]])
            slack[ok] = np.maximum(slack[ok], rounding[step[ok]])
    spread = wide_hi - wide_lo  # W_kj
    peak = np.max(np.maximum(np.abs(a), np.abs(b)), axis=0)  # (n,) S_j
    allowed = DDQ_LOCAL_TOL * spread + DDQ_REL_TOL * peak[None, :] + DDQ_ABS_TOL + slack
    excess = np.maximum(np.maximum(ddq - hi, lo - ddq), 0.0)
    k, j = (int(v) for v in np.unravel_index(int(np.argmax(excess / allowed)), excess.shape))
    where = (f"{names[j]} at t = {t[k]:.4g} s (ddq {ddq[k, j]:.4g}, interpolant "
             f"{lo[k, j]:.4g} to {hi[k, j]:.4g}; allowed {DDQ_LOCAL_TOL:g} x local spread "
             f"{spread[k, j]:.4g} + {DDQ_REL_TOL:g} x peak {peak[j]:.4g} + {DDQ_ABS_TOL:g} "
             f"+ rounding {slack[k, j]:.2g})")
    return float(excess[k, j]), float(allowed[k, j]), where
