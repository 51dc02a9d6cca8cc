"""Independent checker on hand-made trajectories with known (closed-form) defects."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from mmplan import LinePath, Problem, Scenario, Trajectory, get_robot
from mmplan.verify.check import DQ_REL_TOL, check
from mmplan.verify.consistency import TAU_MODEL_TOL
from tests.eta_planner import METHOD

CONTRACT_KEYS = ["status", "planner", "robot", "duration_s", "duration_1cm_s", "duration_1mm_s",
             "final_error_m", "min_clearance_m", "min_self_clearance_m", "min_floor_clearance_m",
             "max_joint_limit_violation",
             "max_torque_violation", "max_pfaffian_residual", "manipulability_start",
             "manipulability_end", "manipulability_min", "compute_time_s", "samples",
             "peak_platform_speed_mps", "peak_platform_yaw_rate_radps",
             "peak_platform_acceleration_mps2", "peak_platform_yaw_acceleration_radps2",
             "peak_velocity", "peak_acceleration", "limit_margins"]
Q0 = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -0.17, 0.35]
R_WHEEL = 0.05


def drive(v: float = 0.2, T: float = 2.0, dt: float = 0.01, lateral: bool = False,
          **columns: Any) -> Trajectory:
    """youbot-3r driving straight along x (wheels rolling) or sliding sideways along y, with
    the model's efforts as tau columns (youbot-3r has torque limits: a plan must carry them)
    unless ``tau`` is given (None: no effort columns)."""
    robot = get_robot("youbot-3r")
    t = np.arange(round(T / dt) + 1) * dt
    q = np.tile(Q0, (len(t), 1))
    dq = np.zeros_like(q)
    if lateral:
        q[:, 1] += v * t
        dq[:, 1] = v
    else:
        for i, scale in ((0, 1.0), (3, 1 / R_WHEEL), (4, 1 / R_WHEEL)):
            q[:, i] += scale * v * t
            dq[:, i] = scale * v
    fields: dict[str, Any] = {"t": t, "q": q, "dq": dq, "ddq": np.zeros_like(q)}
    fields.update(columns)
    if "ee" not in fields:
        fields["ee"] = np.array([robot.ee_position(x) for x in fields["q"]])
    if "tau" not in fields:
        fields["tau"] = model_efforts(fields["q"], fields["dq"], fields["ddq"])
    if fields["tau"] is not None:
        fields.setdefault("actuators", robot.actuators)
    return Trajectory(robot.coordinates, **fields)


def model_efforts(q: Any, dq: Any, ddq: Any) -> Any:
    """youbot-3r's tau = (N^T B)^-1 N^T (M ddq + c) at every sample, (N, 5)."""
    robot = get_robot("youbot-3r")
    return np.array([robot.actuator_efforts(*x) for x in zip(q, dq, ddq, strict=True)])


def problem(goal: dict[str, Any] | None = None, obstacles: list[Any] | None = None,
            **extra: Any) -> Problem:
    data = {"name": "check", "robot": "youbot-3r", "start": Q0,
            "goal": goal or {"position": [5.0, 0.0, 0.3]}, "obstacles": obstacles or [],
            "planner": {"method": METHOD, "eta": [0.0] * 5}, **extra}
    return Scenario.from_dict(data).build()


def test_consistent_drive_passes_and_completion_times_match_closed_form() -> None:
    v, T = 0.23, 2.0  # error levels v * k * dt never land exactly on 1 cm or 1 mm
    tr = drive(v, T)
    goal = tr.ee[-1]
    report = check(tr, problem({"position": goal.tolist(), "tolerance": 0.005}), status="reached")
    assert report.ok, report.failures()
    assert report.max_pfaffian_residual < 1e-12
    assert report.min_clearance_m is None
    assert report.ee_deviation_m == 0.0
    # straight line at speed v towards the goal: error(t) = v (T - t)
    for tol, got in ((0.01, report.duration_1cm_s), (0.001, report.duration_1mm_s),
                     (0.005, report.duration_s)):
        expected = tr.t[np.flatnonzero(v * (T - tr.t) < tol)[0]]
        assert got == pytest.approx(expected, abs=1e-12)
    assert report.final_error_m == pytest.approx(0.0, abs=1e-12)
    robot = get_robot("youbot-3r")
    mus = [robot.manipulability(q) for q in tr.q]
    assert report.manipulability_start == pytest.approx(mus[0], rel=1e-12)
    assert report.manipulability_end == pytest.approx(mus[-1], rel=1e-12)
    assert report.manipulability_min == pytest.approx(min(mus), rel=1e-12)
    summary = report.summary(status="reached", planner="x", compute_time_s=1.5)
    assert list(summary) == CONTRACT_KEYS
    assert summary["samples"] == len(tr.t) and summary["robot"] == "youbot-3r"


def test_lateral_slide_violates_no_slip_by_its_speed() -> None:
    """Sliding sideways at v with theta = 0: |A dq| = |sin(0) * 0 - cos(0) * v| = v."""
    report = check(drive(v=0.3, lateral=True), problem())
    assert report.max_pfaffian_residual == pytest.approx(0.3, rel=1e-12)
    assert any(line.startswith("pfaffian: residual") for line in report.failures())


def test_collision_with_sphere_matches_pointwise_distance() -> None:
    center, radius = np.array([1.0, 0.0, 0.08]), 0.1
    prob = problem(obstacles=[{"shape": "sphere", "center": center.tolist(), "radius": radius}])
    tr = drive(v=0.5, T=2.0)
    report = check(tr, prob)
    robot = prob.robot
    # reference: per-sample collision points (no batching) against the sphere's closed form
    gaps = [np.min(np.linalg.norm(robot.collision_points(q) - center, axis=1) - radius
                   - robot.collision_radii) for q in tr.q]
    assert report.min_clearance_m == pytest.approx(min(gaps), abs=1e-9)
    assert report.min_clearance_m < 0
    failures = report.failures()
    assert any(line.startswith("clearance:") and "obstacles[0]" in line for line in failures)


def test_joint_limit_violation_is_the_excess() -> None:
    tr = drive()
    q, dq = tr.q.copy(), tr.dq.copy()
    rate = 1.0  # q2 rises from -0.17 to 1.83 rad, max 90 deg
    q[:, 6] = -0.17 + rate * tr.t
    dq[:, 6] = rate
    report = check(drive(q=q, dq=dq), problem())
    assert report.max_joint_limit_violation == pytest.approx(q[-1, 6] - np.pi / 2, rel=1e-12)
    assert any(line.startswith("joint limits:") and "q2" in line for line in report.failures())


def test_tau_columns_must_equal_the_model_efforts() -> None:
    """A tau column off the model (wheel1 at t = 0.17 s) fails, naming the actuator;
    the torque limits are judged on the model, so that column hides or adds nothing there."""
    tr = drive()
    honest = np.array(tr.tau)
    tau = honest.copy()
    tau[17, 0] = 1.8  # over the wheel1 limit 1.5 if it were believed
    report = check(drive(tau=tau), problem())
    assert report.tau_model_deviation == pytest.approx(1.8 - honest[17, 0], rel=1e-12)
    assert report.max_torque_violation == 0.0  # the model's wheel efforts are 0 here
    assert any(line.startswith("tau vs model") and "wheel1 at t = 0.17 s" in line
               for line in report.failures())
    nearly = honest.copy()
    nearly[17, 0] += 0.5 * TAU_MODEL_TOL
    assert check(drive(tau=nearly), problem()).ok


def test_torque_limits_are_judged_on_model_efforts() -> None:
    """tau = (N^T B)^-1 N^T (M ddq + c) from q, dq, ddq; tau columns clipped into the limits
    do not hide an excess (they fail tau vs model besides)."""
    tr = drive()
    reference = model_efforts(tr.q, tr.dq, tr.ddq)
    # docs/conventions.md: gravity torques at this arm pose are 0, 0, 0, -8.98, -4.10 N m
    np.testing.assert_allclose(reference[0], [0, 0, 0, -8.98, -4.10], atol=0.01)
    report = check(tr, problem())  # default limits [-10, 0] and [-5, 0] hold
    assert report.torque_source == "model" and report.max_torque_violation == 0.0
    assert report.tau_model_deviation is not None and report.tau_model_deviation < 1e-12
    # demanding q2 <= -9.5 N m: gravity needs about -8.98, so the excess is about 0.52
    strict = problem(limits={"torque": {"max": [1.5, 1.5, 1.0, -9.5, 0.0]}})
    excess = np.max(reference[:, 3] - (-9.5))
    assert excess == pytest.approx(0.52, abs=0.01)
    honest = np.array(tr.tau)
    for tau in (honest, np.minimum(honest, [1.5, 1.5, 1.0, -9.5, 0.0])):
        report = check(drive(tau=tau), strict)
        assert report.max_torque_violation == pytest.approx(excess, rel=1e-9)
        assert any("torque limits" in line and "q2" in line and "model efforts" in line
                   for line in report.failures())
    assert any(line.startswith("tau vs model") for line in report.failures())


def test_effort_columns_are_required_under_torque_limits() -> None:
    """Without tau columns a robot with torque limits fails (the columns are part of the
    plan); without limits (and a method that writes none) they are optional."""
    bare = drive(tau=None)
    report = check(bare, problem())
    assert report.consistency.required == ("tau.*",)
    assert any(line.startswith("columns: effort columns missing (the robot has torque limits)")
               and "tau.wheel1" in line for line in report.failures())
    free = check(bare, problem(limits={"torque": "unlimited"}))
    assert free.consistency.required == () and free.ok, free.failures()


def test_dq_inconsistent_with_q_fails_and_smooth_motion_passes() -> None:
    tr = drive()
    report = check(drive(dq=2 * tr.dq), problem())
    assert report.dq_residual == pytest.approx(0.2 / R_WHEEL, rel=1e-9)  # wheel rate off by v/r
    assert any(line.startswith("dq consistency") for line in report.failures())
    # q1 = A sin(w t): the trapezoid residual is about A w^3 dt^2 / 12, far below the bound
    q, dq = tr.q.copy(), tr.dq.copy()
    A, w, dt = 0.5, 2.0, 0.01
    q[:, 5] = A * np.sin(w * tr.t)
    dq[:, 5] = A * w * np.cos(w * tr.t)
    ok = check(drive(q=q, dq=dq), problem())
    assert ok.dq_residual == pytest.approx(A * w**3 * dt**2 / 12, rel=0.05)
    assert ok.dq_residual < DQ_REL_TOL * ok.dq_scale
    assert not any(line.startswith("dq") for line in ok.failures())


def test_wrong_ee_columns_and_false_status_are_reported() -> None:
    tr = drive()
    shifted = drive(ee=tr.ee + [0.0, 0.0, 0.01])
    report = check(shifted, problem(), status="stalled")
    assert report.ee_deviation_m == pytest.approx(0.01, rel=1e-9)
    assert any(line.startswith("end effector") for line in report.failures())
    lie = check(tr, problem(), status="reached")  # goal (5, 0, 0.3) is far away
    assert any(line.startswith("status: planner says 'reached'") for line in lie.failures())


def test_path_task_is_completed_only_when_the_trajectory_covers_it() -> None:
    v = 0.2
    full = drive(v=v, T=3.0)
    path = {"kind": "line", "start": full.ee[0].tolist(), "velocity": [v, 0.0, 0.0],
            "duration": 3.0}
    prob = problem({"path": path, "tolerance": 1e-6})
    assert isinstance(prob.task, LinePath)
    done = check(full, prob, status="reached")
    assert done.task_completed and done.duration_s == 0.0 and done.ok
    partial = check(drive(v=v, T=1.5), prob, status="reached")
    assert partial.final_error_m < 1e-9 and not partial.task_completed
    assert partial.duration_s is None
    assert any(line.startswith("status:") for line in partial.failures())


def test_nonfinite_trajectory_fails() -> None:
    tr = drive()
    q = tr.q.copy()
    q[3, 0] = np.nan
    report = check(drive(q=q), problem())
    assert not report.finite and not report.ok


def test_omnidirectional_robot_has_no_pfaffian_constraint() -> None:
    """h = 0: any platform motion is admissible; the residual is exactly 0."""
    robot = get_robot("omni-3dof")
    t = np.linspace(0.0, 1.0, 51)
    q = np.zeros((51, 6))
    q[:, 1] = 0.3 * t  # sideways
    q[:, 3] = 0.5
    dq = np.zeros_like(q)
    dq[:, 1] = 0.3
    ee = np.array([robot.ee_position(x) for x in q])
    tr = Trajectory(robot.coordinates, t, q, dq, np.zeros_like(q), ee)
    prob = Scenario.from_dict({"name": "omni", "robot": "omni-3dof", "start": q[0].tolist(),
                               "goal": {"position": ee[-1].tolist()},
                               "planner": {"method": METHOD, "eta": [0.0] * 6}}).build()
    report = check(tr, prob, status="reached")
    assert report.max_pfaffian_residual == 0.0 and report.ok, report.failures()
