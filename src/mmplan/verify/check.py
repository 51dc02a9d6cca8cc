r"""Independent verification of a trajectory, from physics and the scenario alone.

Nothing here trusts the planner: the end effector comes from the robot's forward kinematics,
clearance from the exact point-to-surface distance to the ORIGINAL (not enlarged) obstacles at
the robot's collision points, and the task error from the task itself. Every quantity is
evaluated over all N samples at once (CasADi ``Function.map``).

Pass criteria (:meth:`CheckReport.failures` names each one that fails):

* finite values; ee columns equal FK(q) within ``EE_TOL``;
* clearance >= 0 (robot collision spheres vs original obstacles);
* floor clearance >= ``FLOOR_TOL`` (0 m) of the ground spheres above the floor z = h
  (``Scene.ground``; none when it is None) at every sample and on the interpolated motion
  between samples (:mod:`.floor`);
* self-clearance >= 0 for robots with self-collision pairs (URDF robots: the robot's own
  :class:`~mmplan.robot.self_collision.SelfCollision` pairs and their sphere distances);
* joint limits (arm coordinates) within ``LIMIT_TOL``; actuator efforts within ``TORQUE_TOL``,
  the efforts recomputed from the model (q, dq, ddq), never the file's ``tau`` columns;
* Pfaffian residual :math:`\max_t \|A(q) \dot q\|_2 \le` ``PFAFFIAN_TOL`` (1e-6 m/s);
* dq consistent with q: per step, the trapezoid increment of dq matches the increment of q,
  :math:`r_i = \|(q_{i+1} - q_i)/\Delta t_i - (\dot q_i + \dot q_{i+1})/2\|_\infty`
  (the residual of q against the cumulative trapezoid integral of dq, normalized by the step),
  with :math:`\max_i r_i \le` ``DQ_REL_TOL`` :math:`\cdot \max(\max|\dot q|, 10^{-3})`;
* the columns tied to each other and to the scenario (:mod:`.consistency`): first sample at
  t = 0 on the scenario's start, required effort columns present, ``tau`` equal to the model
  efforts, ddq within the range of the interpolant's acceleration on the adjacent steps;
* the claimed status one of :class:`~mmplan.trajectory.Status`, and
  ``reached`` exactly when the task is completed (T(tol) exists and the trajectory
  covers the task: a path's duration, a segment's parameter 1);
* velocity and acceleration limits on the dq/ddq columns and on what every motion through
  two consecutive samples needs (secants of q, least peak acceleration from q and dq),
  slack 1e-6 relative, :mod:`.rates`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from mmplan.arrays import Array
from mmplan.errors import InputError, require
from mmplan.problem import Problem
from mmplan.robot.tree import JointKind
from mmplan.task import DrawSegment, Task, TrackPath, completion_time
from mmplan.trajectory import Status, Trajectory
from mmplan.verify.consistency import Consistency, check_consistency
from mmplan.verify.floor import FLOOR_TOL, floor_clearance_over
from mmplan.verify.native import check_functions
from mmplan.verify.rates import RateReport, check_rates
from mmplan.verify.self_clearance import self_clearance_over

EE_TOL = 1e-6  # [m]
LIMIT_TOL = 1e-9  # [rad or m]
TORQUE_TOL = 1e-6  # [N m or N]
PFAFFIAN_TOL = 1e-6  # [m/s]
DQ_REL_TOL = 1e-2  # relative to max |dq|
STATUSES = tuple(s.value for s in Status)


@dataclass(frozen=True)
class CheckReport:
    """Metrics recomputed from a trajectory (SI units; None where not applicable).

    Attributes:
        robot: Robot name.
        samples: Number of samples N.
        finite: No NaN or inf in any column.
        ee_deviation_m: max_t |FK(q) - ee column|.
        min_clearance_m: Smallest gap between collision spheres and original obstacles
            (None without obstacles); ``clearance_where`` describes where.
        min_self_clearance_m: Smallest signed distance of the robot's self-collision sphere
            pairs (None for a robot without pairs); ``self_clearance_where``: which bodies and
            when.
        max_joint_limit_violation: Largest excess over the arm joint limits (0 inside);
            ``joint_where`` describes where.
        max_torque_violation: Largest excess over the actuator limits (0 within, or without
            finite limits); ``torque_where`` describes where. The efforts checked are the
            model's tau = (N^T B)^-1 N^T (M ddq + c) ([PajakPajak] eq. (22)) from q, dq, ddq;
            the tau columns must equal them (``consistency``).
        torque_source: ``"model"``, or ``""`` (no finite limits).
        max_pfaffian_residual: max_t |A(q) dq|_2; ``pfaffian_where``: at which time.
        dq_residual: Step-normalized trapezoid residual of q against dq (see module doc).
        dq_scale, ddq_scale: max |dq| (scale of the relative tolerance), max |ddq|.
        duration_s: T(tol) when the task is completed, else None.
        duration_1cm_s, duration_1mm_s: T(1 cm), T(1 mm) (None if never).
        final_error_m: Task error at the last sample.
        tolerance: The task tolerance [m].
        task_completed: T(tol) exists and the trajectory covers the task.
        manipulability_start, manipulability_end, manipulability_min: mu along the run.
        status: The status claimed by the planner (None when not given).
        rates: Peaks of velocities and accelerations and the checks of their limits.
        consistency: Start, required columns, tau vs model, ddq vs the interpolant.
        min_floor_clearance_m: Smallest height of the ground spheres above the floor
            (:mod:`.floor`; samples and interpolated motion), None without a floor or
            ground spheres; ``floor_where``: which sphere, when, and the floor height.
    """

    robot: str
    samples: int
    finite: bool
    ee_deviation_m: float
    min_clearance_m: float | None
    clearance_where: str
    max_joint_limit_violation: float
    joint_where: str
    max_torque_violation: float
    torque_where: str
    torque_source: str
    max_pfaffian_residual: float
    pfaffian_where: str
    dq_residual: float
    dq_scale: float
    ddq_scale: float
    duration_s: float | None
    duration_1cm_s: float | None
    duration_1mm_s: float | None
    final_error_m: float
    tolerance: float
    task_completed: bool
    manipulability_start: float
    manipulability_end: float
    manipulability_min: float
    status: str | None = None
    rates: RateReport = field(default_factory=RateReport)
    min_self_clearance_m: float | None = None
    self_clearance_where: str = ""
    consistency: Consistency = field(default_factory=Consistency)
    min_floor_clearance_m: float | None = None
    floor_where: str = ""

    @property
    def tau_model_deviation(self) -> float | None:
        """max |tau column - model efforts| (None without tau columns)."""
        return self.consistency.tau_model_deviation

    @property
    def ok(self) -> bool:
        """True when every check passes."""
        return not self.failures()

    def failures(self) -> list[str]:
        """One line per failed check, naming the check, the value and where."""
        out: list[str] = []
        if not self.finite:
            out.append("finite: the trajectory holds NaN or inf values")
        if not self.ee_deviation_m <= EE_TOL:
            out.append(f"end effector: ee columns differ from FK(q) by {self.ee_deviation_m:.3g} m "
                       f"(> {EE_TOL:g} m)")
        if self.min_clearance_m is not None and not self.min_clearance_m >= 0:
            out.append(f"clearance: {self.min_clearance_m:.4g} m < 0, {self.clearance_where}")
        floor = self.min_floor_clearance_m
        if floor is not None and not floor >= FLOOR_TOL:
            out.append(f"floor: clearance {floor:.4g} m < {FLOOR_TOL:g} m, {self.floor_where}")
        if self.min_self_clearance_m is not None and not self.min_self_clearance_m >= 0:
            out.append(f"self-collision: {self.min_self_clearance_m:.4g} m < 0, "
                       f"{self.self_clearance_where}")
        if not self.max_joint_limit_violation <= LIMIT_TOL:
            out.append(f"joint limits: exceeded by {self.max_joint_limit_violation:.4g}, "
                       f"{self.joint_where}")
        if not self.max_torque_violation <= TORQUE_TOL:
            out.append(f"torque limits: exceeded by {self.max_torque_violation:.4g}, "
                       f"{self.torque_where} ({self.torque_source} efforts)")
        if not self.max_pfaffian_residual <= PFAFFIAN_TOL:
            out.append(f"pfaffian: residual |A(q) dq| = {self.max_pfaffian_residual:.3g} > "
                       f"{PFAFFIAN_TOL:g}, {self.pfaffian_where}")
        if not self.dq_residual <= DQ_REL_TOL * max(self.dq_scale, 1e-3):
            out.append(f"dq consistency: q differs from the integral of dq by "
                       f"{self.dq_residual:.3g}/s per step (max |dq| = {self.dq_scale:.3g})")
        out += self.consistency.failures()
        out += self.rates.failures()
        if self.status is not None and self.status not in STATUSES:
            out.append(f"status: {self.status!r} is not one of {', '.join(STATUSES)}")
            return out
        # "reached" needs the task completed; another status with the task completed is
        # honest only when the plan breaks something else (a limit, a collision, ...).
        reached = self.status == Status.REACHED
        if self.status is not None and (
            (reached and not self.task_completed)
            or (not reached and self.task_completed and not out)
        ):
            done = "completed" if self.task_completed else "not completed"
            out.append(f"status: planner says {self.status!r} but the task is {done} "
                       f"(final error {self.final_error_m:.3g} m, tolerance {self.tolerance:g} m)")
        return out

    def summary(self, *, status: str, planner: str, compute_time_s: float) -> dict[str, Any]:
        """summary.json content (docs/conventions.md keys, in order) with the run's own fields."""
        r = self.rates
        return {
            "status": status,
            "planner": planner,
            "robot": self.robot,
            "duration_s": self.duration_s,
            "duration_1cm_s": self.duration_1cm_s,
            "duration_1mm_s": self.duration_1mm_s,
            "final_error_m": self.final_error_m,
            "min_clearance_m": self.min_clearance_m,
            "min_self_clearance_m": self.min_self_clearance_m,
            "min_floor_clearance_m": self.min_floor_clearance_m,
            "max_joint_limit_violation": self.max_joint_limit_violation,
            "max_torque_violation": self.max_torque_violation,
            "max_pfaffian_residual": self.max_pfaffian_residual,
            "manipulability_start": self.manipulability_start,
            "manipulability_end": self.manipulability_end,
            "manipulability_min": self.manipulability_min,
            "compute_time_s": compute_time_s,
            "samples": self.samples,
            "peak_platform_speed_mps": r.peak_platform_speed_mps,
            "peak_platform_yaw_rate_radps": r.peak_platform_yaw_rate_radps,
            "peak_platform_acceleration_mps2": r.peak_platform_acceleration_mps2,
            "peak_platform_yaw_acceleration_radps2": r.peak_platform_yaw_acceleration_radps2,
            "peak_velocity": dict(r.peak_velocity),
            "peak_acceleration": dict(r.peak_acceleration),
            "limit_margins": r.limit_margins,
        }


def _mapped(functions: Mapping[str, ca.Function], name: str, *columns: Array) -> Array:
    """Evaluate ``functions[name]`` (:func:`~mmplan.verify.native.check_functions`) on N
    samples at once; ``columns`` are (N, k), the result is (rows, N * cols) of its output."""
    fn = functions[name].map(columns[0].shape[0])
    rows, cols = fn.size_out(0)
    if not fn.sparsity_out(0).is_dense():
        return np.asarray(fn(*[c.T for c in columns]), dtype=float)
    # column-major buffers: (N, k) row-major in, (cols, rows) row-major out (no DM copies)
    inputs = [np.ascontiguousarray(c, dtype=float) for c in columns]
    out = np.empty((cols, rows))
    buffer, run = fn.buffer()  # the binding takes each size from the buffer (not the stub)
    for i, column in enumerate(inputs):
        buffer.set_arg(i, column.data)  # type: ignore[call-arg]
    buffer.set_res(0, out.data)  # type: ignore[call-arg]
    run()
    return np.ascontiguousarray(out.T)  # the layout (and sums) of the DM path


def _task_end(task: Task) -> float | None:
    """The time the trajectory must reach for the task to be complete (None: any)."""
    if isinstance(task, TrackPath):
        return float(task.duration)
    if isinstance(task, DrawSegment):
        return 1.0
    return None


def _trapezoid_residual(t: Array, x: Array, dx: Array) -> float:
    """max_i |(x_{i+1} - x_i)/dt_i - (dx_i + dx_{i+1})/2|_inf (0 for one sample)."""
    if len(t) < 2:
        return 0.0
    dt = np.diff(t)[:, None]
    r = np.diff(x, axis=0) / dt - 0.5 * (dx[1:] + dx[:-1])
    return float(np.max(np.abs(r))) if r.size else 0.0


def _excess(values: Array, lo: Array, hi: Array) -> Array:
    """max(values - hi, lo - values, 0) elementwise, (N, k)."""
    return np.maximum(np.maximum(values - hi, lo - values), 0.0)


def check(trajectory: Trajectory, problem: Problem, status: str | None = None) -> CheckReport:
    """Verify ``trajectory`` against ``problem`` (robot and limits, original scene, task).

    Args:
        trajectory: The trajectory to check (its q, dq, ddq, tau, ee columns).
        problem: The problem it claims to solve.
        status: The status the planner reported (a :class:`Status` or its string, as read
            from a summary.json); checked against the task when given: a string that is no
            status is a failed check, not an error (it is the claim being judged).

    Raises:
        InputError: an argument of another type, or a trajectory of another robot.
    """
    require(trajectory, Trajectory, "trajectory", "a Trajectory")
    require(problem, Problem, "problem", "a Problem (Scenario.build())")
    if status is not None and not isinstance(status, str):
        raise InputError("status", f"expected a Status, its string or None, got "
                         f"{type(status).__name__}")
    robot, tr = problem.robot, trajectory
    if tr.coordinates != robot.coordinates:
        raise InputError("trajectory", f"coordinates {tr.coordinates} do not match robot "
                         f"{robot.name} {robot.coordinates}")
    # contiguous copies: results must not depend on the memory layout a planner produced
    t, q, dq, ddq = (np.ascontiguousarray(a, dtype=float) for a in (tr.t, tr.q, tr.dq, tr.ddq))
    N, n = q.shape
    fns = check_functions(robot)
    ee = _mapped(fns, "ee_position", q).T  # (N, 3)
    ee_dev = float(np.max(np.linalg.norm(ee - tr.ee, axis=1)))

    clearance, clearance_where = None, ""
    if problem.scene.obstacles and robot.collision:
        P = len(robot.collision)
        pts = _mapped(fns, "collision_points", q).T  # (N * P, 3), sample-major
        clearance, row, o = problem.scene.nearest(pts, np.tile(robot.collision_radii, N))
        sample, point = divmod(row, P)
        clearance_where = (f"obstacles[{o}] vs robot point {point} "
                           f"(on {robot.collision[point].body}) at t = {t[sample]:.4g} s")

    self_clearance, self_where = self_clearance_over(robot, q, t)
    floor, floor_where = floor_clearance_over(robot, problem.scene.ground, t, q, dq)

    lim = robot.limits
    arm = list(robot.arm_indices)
    joint_viol, joint_where = _worst(_excess(q[:, arm], lim.joint_min, lim.joint_max), t,
                                     [robot.coordinates[i] for i in arm])
    torque_viol, torque_where, torque_source = 0.0, "", ""
    tau_model = _mapped(fns, "tau", q, dq, ddq).T if robot.actuators else None  # (N, n_act)
    if lim.has_torque_limits and tau_model is not None:
        torque_source = "model"
        torque_viol, torque_where = _worst(_excess(tau_model, lim.torque_min, lim.torque_max),
                                           t, list(robot.actuators))

    pfaff, pfaff_where = 0.0, ""
    if robot.h > 0:
        A = _mapped(fns, "pfaffian", q).reshape(robot.h, N, n)  # A[:, k, :] = A(q_k)
        res = np.linalg.norm(np.einsum("hkn,kn->kh", A, dq), axis=1)
        worst = int(np.argmax(res))
        pfaff, pfaff_where = float(res[worst]), f"at t = {t[worst]:.4g} s"

    task = problem.task
    errors = task.errors(t, ee)
    tol = float(task.tolerance)
    t_tol = completion_time(t, errors, tol)
    end = _task_end(task)
    completed = t_tol is not None and (end is None or t[-1] >= end - 1e-9)
    mu = _mapped(fns, "manipulability", q).reshape(N)
    units = {j.coordinate: "m" if j.kind is JointKind.PRISMATIC else "rad"
             for j in robot.tree.joints if j.coordinate is not None}
    rates = check_rates(t, q, dq, ddq, robot.coordinates, lim.rates, units,
                        timed=not isinstance(task, DrawSegment))  # a segment's t is s in [0, 1]
    return CheckReport(
        robot=robot.name, samples=N, finite=tr.is_finite(), ee_deviation_m=ee_dev,
        min_clearance_m=clearance, clearance_where=clearance_where,
        max_joint_limit_violation=joint_viol, joint_where=joint_where,
        max_torque_violation=torque_viol, torque_where=torque_where,
        torque_source=torque_source,
        max_pfaffian_residual=pfaff, pfaffian_where=pfaff_where,
        dq_residual=_trapezoid_residual(t, q, dq), dq_scale=float(np.max(np.abs(dq))),
        ddq_scale=float(np.max(np.abs(ddq))),
        duration_s=t_tol if completed else None,
        duration_1cm_s=completion_time(t, errors, 0.01),
        duration_1mm_s=completion_time(t, errors, 0.001),
        final_error_m=float(errors[-1]), tolerance=tol, task_completed=bool(completed),
        manipulability_start=float(mu[0]), manipulability_end=float(mu[-1]),
        manipulability_min=float(np.min(mu)), status=None if status is None else str(status),
        min_self_clearance_m=self_clearance, self_clearance_where=self_where,
        rates=rates, consistency=check_consistency(tr, problem, tau_model),
        min_floor_clearance_m=floor, floor_where=floor_where,
    )


def _worst(excess: Array, t: Array, names: list[str]) -> tuple[float, str]:
    """Largest entry of ``excess`` (N, k) and where (column name, time)."""
    if excess.size == 0:
        return 0.0, ""
    k, j = (int(i) for i in np.unravel_index(int(np.argmax(excess)), excess.shape))
    return float(excess[k, j]), f"{names[j]} at t = {t[k]:.4g} s"
