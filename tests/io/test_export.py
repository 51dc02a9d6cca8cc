"""Export at a fixed control rate: the interpolant, the checks it passes, the ROS 2 bag.

The plan used throughout is youbot3r-obstacles-torque with the youBot's rate limits (time
scaling: uneven steps of a few hundredths of a second, wheel accelerations at their limit,
efforts that jump at the samples, a differential drive with three Pfaffian rows).
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import mmplan
from mmplan import interpolant
from mmplan.errors import InputError
from mmplan.io import ros2
from mmplan.io.control_rate import control_times, pfaffian_residuals, resample_detailed
from mmplan.io.export import export_plan, resample
from mmplan.verify.check import PFAFFIAN_TOL, check
from mmplan.verify.rates import check_rates

RATE = 100.0


@pytest.fixture(scope="module")
def plan_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """youbot3r-obstacles-torque planned and written once for this module."""
    sc = mmplan.load_scenario("youbot3r-obstacles-torque")
    problem = sc.build()
    result = mmplan.get_planner(sc.method)().plan(problem)
    return mmplan.write_plan(tmp_path_factory.mktemp("plan") / "yb", result, problem, sc)


@pytest.fixture(scope="module")
def plan(plan_dir: Path) -> tuple[mmplan.Trajectory, mmplan.Problem, str]:
    tr, sc = mmplan.read_plan(plan_dir)
    return tr, sc.build(), str(mmplan.read_summary(plan_dir)["status"])


def test_control_times_are_uniform_and_end_at_the_plan_end() -> None:
    t = control_times(0.5, 2.00009, 100.0)
    assert t[0] == 0.5 and t[-1] == 2.00009 and len(t) == 152
    np.testing.assert_allclose(np.diff(t)[:-1], 0.01, rtol=0, atol=1e-12)
    assert 1e-5 <= t[-1] - t[-2] <= 0.01001
    exact = control_times(0.0, 1.5, 100.0)  # a multiple of the step: no short last step
    assert len(exact) == 151 and exact[-1] == 1.5
    np.testing.assert_allclose(np.diff(exact), 0.01, atol=1e-12)
    almost = control_times(0.0, 1.5 + 1e-9, 100.0)  # no step of a nanosecond
    assert len(almost) == 151 and almost[-1] == 1.5 + 1e-9


def test_the_export_samples_the_plans_interpolant(plan: Any) -> None:
    """q and ddq are the cubic Hermite's (mmplan.interpolant); dq is its velocity projected
    onto ker A(q); at the plan's own samples ddq is the Hermite's, not the plan's one-sided
    value."""
    tr, problem, _ = plan
    res = resample_detailed(tr, RATE, problem.robot)
    out = res.trajectory
    q, dq, ddq = interpolant.evaluate(tr.t, tr.q, tr.dq, out.t)
    np.testing.assert_allclose(out.q, q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(out.ddq, ddq, rtol=0, atol=1e-9)
    np.testing.assert_allclose(out.dq, dq, rtol=0, atol=res.dq_projection + 1e-15)
    a, b = interpolant.step_accelerations(tr.t, tr.q, tr.dq)
    assert np.array_equal(out.ddq[0], a[0]) and np.allclose(out.ddq[-1], b[-1], atol=1e-9)
    assert np.max(np.abs(a[0] - tr.ddq[0])) > 1e-3  # the plan wrote its own value there


@pytest.mark.parametrize("rate", [RATE, 1000.0, 50.0])
def test_resampled_plan_passes_every_check_the_plan_passes(plan: Any, rate: float) -> None:
    """The plan holds its rate limits on its interpolant (wheels at 20 rad/s^2), and so does
    the export, at every rate: every check passes, rate limits included."""
    tr, problem, status = plan
    original = check(tr, problem, status=status)
    assert original.failures() == []
    assert max(c.peak / c.limit for c in original.rates.checks) > 1 - 1e-9  # limits bind
    res = resample_detailed(tr, rate, problem.robot)
    out = res.trajectory
    assert out.samples == len(control_times(tr.t[0], tr.t[-1], rate))
    np.testing.assert_allclose(np.diff(out.t)[:-1], 1 / rate, rtol=0, atol=1e-12)
    assert out.t[-1] == tr.t[-1]
    report = check(out, problem, status=status)
    assert report.failures() == []
    assert report.max_pfaffian_residual <= PFAFFIAN_TOL
    assert report.task_completed == original.task_completed
    # measured residual of the interpolant (module doc: about 2.5e-5 m/s), removed by projection
    assert 1e-7 < res.pfaffian_interpolated < 1e-4
    assert res.pfaffian <= 1e-12 and res.dq_projection <= 2 * res.pfaffian_interpolated
    np.testing.assert_array_equal(
        pfaffian_residuals(problem.robot, out.q, out.dq).max(), res.pfaffian)


def test_a_plan_breaking_a_limit_between_its_samples_exports_with_that_failure(
        plan: Any) -> None:
    """The same plan checked against a wheel acceleration limit of 19.9 rad/s^2 (it holds
    20): the plan's check and the export's check both fail on it."""
    tr, problem, _ = plan
    rates = problem.robot.limits.rates
    tight = dataclasses.replace(rates, acceleration={**rates.acceleration, "phi1": 19.9})
    for trajectory in (tr, resample(tr, RATE, problem.robot)):
        assert check_rates(trajectory.t, trajectory.q, trajectory.dq, trajectory.ddq,
                           problem.robot.coordinates, rates).failures() == []
        lines = check_rates(trajectory.t, trajectory.q, trajectory.dq, trajectory.ddq,
                            problem.robot.coordinates, tight).failures()
        assert any(line.startswith("rate limits: |ddq| phi1 = ") and "> limit 19.9 " in line
                   for line in lines), lines


def test_q_dq_ddq_are_derivatives_of_one_curve(plan: Any) -> None:
    """Simpson's rule is exact for the cubic's dq (quadratic) and ddq (linear): on every
    control step inside one original step, q and dq increase exactly by the integrals."""
    tr, problem, _ = plan
    coarse = resample_detailed(tr, RATE, problem.robot)
    fine = resample(tr, 2 * RATE, problem.robot)
    a, m = coarse.trajectory, fine
    k = np.arange(len(a.t) - 2)  # uniform steps (the last one is shorter)
    np.testing.assert_allclose(m.t[2 * k + 1], 0.5 * (a.t[k] + a.t[k + 1]), atol=1e-12)
    inside = np.searchsorted(tr.t, a.t[k], "right") == np.searchsorted(tr.t, a.t[k + 1], "left")
    assert inside.sum() > 0.5 * len(k)
    k, h = k[inside], 1 / RATE

    def simpson(f: np.ndarray, fm: np.ndarray) -> np.ndarray:
        return h / 6 * (f[k] + 4 * fm[2 * k + 1] + f[k + 1])

    slack = 4 * coarse.dq_projection  # dq was projected onto ker A(q) by this much
    np.testing.assert_allclose(a.q[k + 1] - a.q[k], simpson(a.dq, m.dq), rtol=0,
                               atol=1e-9 + h * slack)
    np.testing.assert_allclose(a.dq[k + 1] - a.dq[k], simpson(a.ddq, m.ddq), rtol=0,
                               atol=1e-9 + slack)
    # and by plain finite differences: central differences of q give dq within 0.5 %
    central = (a.q[2:-1] - a.q[:-3]) / (2 * h)
    assert np.max(np.abs(central - a.dq[1:-2])) <= 5e-3 * np.max(np.abs(a.dq))


def test_values_match_the_plan_where_the_samples_coincide(plan: Any) -> None:
    tr, problem, _ = plan
    once = resample(tr, RATE, problem.robot)
    assert np.array_equal(once.q[[0, -1]], tr.q[[0, -1]])
    np.testing.assert_allclose(once.dq[[0, -1]], tr.dq[[0, -1]], rtol=0, atol=1e-15)  # projected
    # resampling at half the rate: every other sample coincides with one of ``once`` (ddq
    # there is that of the new interpolant, whose steps span two of ``once``'s, and tau with it)
    half = resample(once, RATE / 2, problem.robot)
    np.testing.assert_allclose(half.t[:-1], once.t[:-1:2][: len(half.t) - 1], atol=1e-12)
    for name in ("q", "dq", "ee", "u"):
        got, want = getattr(half, name)[:-1], getattr(once, name)[:-1:2][: len(half.t) - 1]
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-10, err_msg=name)


def test_tau_is_the_model_u_is_linear_and_ee_is_forward_kinematics(plan: Any) -> None:
    """tau: the efforts the exported motion needs (model of q, dq, ddq), within the torque
    limits; it differs from a linear interpolation of the plan's efforts where the time
    scaling switches (about 0.86 N m at 100 Hz)."""
    tr, problem, _ = plan
    robot = problem.robot
    out = resample(tr, RATE, robot)
    assert out.tau is not None and tr.tau is not None and out.u is not None
    assert out.actuators == robot.actuators
    for k in (0, 333, out.samples - 1):
        model = robot.actuator_efforts(out.q[k], out.dq[k], out.ddq[k])
        np.testing.assert_allclose(out.tau[k], model, rtol=0, atol=1e-9)
    lo, hi = robot.limits.torque_min, robot.limits.torque_max
    assert np.all(out.tau >= lo) and np.all(out.tau <= hi)
    linear = np.column_stack([np.interp(out.t, tr.t, tr.tau[:, j])
                              for j in range(tr.tau.shape[1])])
    assert 0.1 < np.max(np.abs(out.tau - linear)) < 1.5
    np.testing.assert_allclose(out.u, np.interp(out.t, tr.t, tr.u), rtol=0, atol=1e-12)
    for k in (0, 333, out.samples - 1):
        np.testing.assert_allclose(out.ee[k], robot.ee_position(out.q[k]), atol=1e-12)


@pytest.mark.parametrize("rate", [0.0, -5.0, 0.5, math.nan, math.inf, 2e4])
def test_bad_rates_are_input_errors(plan: Any, rate: float) -> None:
    tr, problem, _ = plan
    with pytest.raises(InputError, match="--rate"):
        resample(tr, rate, problem.robot)


def test_export_plan_writes_a_checked_folder(plan_dir: Path, tmp_path: Path) -> None:
    done = export_plan(plan_dir, rate=RATE, out=tmp_path / "E")
    summary = json.loads((tmp_path / "E" / "summary.json").read_text())
    original = json.loads((plan_dir / "summary.json").read_text())
    assert summary["samples"] == done.resampled.trajectory.samples
    assert summary["status"] == original["status"] and summary["planner"] == original["planner"]
    export = summary["planner_info"]["export"]
    assert export["rate_hz"] == RATE and export["source_samples"] == original["samples"]
    assert list(done.failures) == summary["check_failures"] == original["check_failures"] == []
    again, _ = mmplan.read_plan(tmp_path / "E")
    np.testing.assert_array_equal(again.q, done.resampled.trajectory.q)
    assert (tmp_path / "E" / "history.csv").is_file() == (plan_dir / "history.csv").is_file()


def test_export_refuses_a_segment_parameter_plan(tmp_path: Path) -> None:
    """A manipulability-area plan's t is the segment parameter: no control rate."""
    sc = mmplan.load_scenario("wall-segment")
    problem = sc.build()
    q = np.tile(np.asarray(problem.start, dtype=float), (2, 1))
    ee = np.array([problem.robot.ee_position(x) for x in q])
    tr = mmplan.Trajectory(problem.robot.coordinates, np.array([0.0, 1.0]), q,
                           np.zeros_like(q), np.zeros_like(q), ee)
    result = mmplan.PlanResult(mmplan.Status.STALLED, tr, sc.method)
    mmplan.write_plan(tmp_path / "wall", result, problem, sc)
    with pytest.raises(InputError, match="segment parameter"):
        export_plan(tmp_path / "wall", out=tmp_path / "E")
    assert not (tmp_path / "E").exists()


# ----------------------------------------------------------------------------- ROS 2 bag

def _read_bag(path: Path) -> dict[str, list[tuple[int, Any]]]:
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)  # reads what was written with Humble's types
    messages: dict[str, list[tuple[int, Any]]] = {}
    with Reader(path) as reader:
        for conn, stamp, raw in reader.messages():
            messages.setdefault(conn.topic, []).append(
                (stamp, store.deserialize_cdr(raw, conn.msgtype)))
    return messages


def test_bag_read_back_matches_the_exported_trajectory(plan_dir: Path, tmp_path: Path) -> None:
    pytest.importorskip("rosbags", reason="rosbags not installed (pip install 'mmplan[ros]')")
    done = export_plan(plan_dir, rate=RATE, out=tmp_path / "E", ros2=tmp_path / "bag")
    csv, _ = mmplan.read_plan(tmp_path / "E")  # trajectory.csv of the exported plan
    original, _ = mmplan.read_plan(plan_dir)
    N = csv.samples
    msgs = _read_bag(tmp_path / "bag")
    assert {k: len(v) for k, v in msgs.items()} == {
        "/joint_trajectory": 1, "/base_path": 1, "/cmd_vel": N}
    assert done.bag is not None and done.bag.counts == {
        "/joint_trajectory": 1, "/base_path": 1, "/cmd_vel": N}

    jt = msgs["/joint_trajectory"][0][1]
    assert jt.joint_names == ["phi1", "phi2", "q1", "q2", "q3"] and len(jt.points) == N
    pos = np.array([p.positions for p in jt.points])
    vel = np.array([p.velocities for p in jt.points])
    acc = np.array([p.accelerations for p in jt.points])
    eff = np.array([p.effort for p in jt.points])
    tfs = np.array([p.time_from_start.sec + 1e-9 * p.time_from_start.nanosec for p in jt.points])
    np.testing.assert_array_equal(pos, csv.q[:, 3:])  # float64 both ways: exact
    np.testing.assert_array_equal(vel, csv.dq[:, 3:])
    np.testing.assert_array_equal(acc, csv.ddq[:, 3:])
    assert csv.tau is not None
    np.testing.assert_array_equal(eff, csv.tau)  # wheel1, wheel2 drive phi1, phi2; arm joints
    np.testing.assert_allclose(tfs, csv.t - csv.t[0], rtol=0, atol=1e-9)  # ns rounding
    # against the planner's own trajectory.csv at its sample times: the interpolant passes
    # through them (start and end exactly; elsewhere by linear interpolation of the bag's
    # points, within step^2 / 8 * max |ddq| at 100 Hz)
    np.testing.assert_array_equal(pos[[0, -1]], original.q[[0, -1], 3:])
    between = np.column_stack([np.interp(original.t, tfs, pos[:, j]) for j in range(5)])
    assert np.max(np.abs(between - original.q[:, 3:])) <= 0.01**2 / 8 * np.abs(csv.ddq).max()

    stamps = np.array([s for s, _ in msgs["/cmd_vel"]])
    np.testing.assert_array_equal(stamps, np.round((csv.t - csv.t[0]) * 1e9).astype(np.int64))
    twist = np.array([[m.linear.x, m.linear.y, m.linear.z, m.angular.x, m.angular.y,
                       m.angular.z] for _, m in msgs["/cmd_vel"]])
    c, s = np.cos(csv.q[:, 2]), np.sin(csv.q[:, 2])
    np.testing.assert_allclose(twist[:, 0], c * csv.dq[:, 0] + s * csv.dq[:, 1], atol=1e-12)
    np.testing.assert_allclose(twist[:, 5], csv.dq[:, 2], atol=1e-12)
    assert not twist[:, 1:5].any()  # differential drive: no lateral, no roll/pitch
    # the lateral velocity left out is the Pfaffian residual (row 3: no side slip)
    assert np.max(np.abs(-s * csv.dq[:, 0] + c * csv.dq[:, 1])) <= PFAFFIAN_TOL
    # wheel rates give the same base velocity: v = r (dphi1 + dphi2) / 2
    np.testing.assert_allclose(twist[:, 0], 0.05 * (vel[:, 0] + vel[:, 1]) / 2, atol=1e-6)

    path = msgs["/base_path"][0][1]
    assert path.header.frame_id == "odom" and len(path.poses) == N
    xy = np.array([[p.pose.position.x, p.pose.position.y] for p in path.poses])
    yaw = np.array([2 * math.atan2(p.pose.orientation.z, p.pose.orientation.w)
                    for p in path.poses])
    np.testing.assert_array_equal(xy, csv.q[:, :2])
    np.testing.assert_allclose(np.angle(np.exp(1j * (yaw - csv.q[:, 2]))), 0, atol=1e-12)


def test_omnidirectional_twists_carry_linear_y() -> None:
    pytest.importorskip("rosbags", reason="rosbags not installed (pip install 'mmplan[ros]')")
    robot = mmplan.get_robot("omni-3dof")
    q = np.zeros((2, robot.n))
    q[:, 2] = [0.5, 0.6]
    dq = np.zeros_like(q)
    dq[:, :3] = [[0.3, 0.4, 0.1], [0.2, -0.1, 0.0]]
    tr = mmplan.Trajectory(robot.coordinates, np.array([0.0, 0.01]), q, dq, np.zeros_like(q),
                           np.zeros((2, 3)))
    twists, dropped = ros2.base_twists(robot, tr)
    c, s = math.cos(0.5), math.sin(0.5)
    np.testing.assert_allclose(twists[0], [c * 0.3 + s * 0.4, -s * 0.3 + c * 0.4, 0.1])
    assert dropped == 0.0 and twists[1, 1] != 0


def test_car_steering_gets_the_steer_effort() -> None:
    robot = mmplan.get_robot("car-rtr")
    q = np.zeros((2, robot.n))
    tau = np.arange(2 * len(robot.actuators), dtype=float).reshape(2, -1)
    tr = mmplan.Trajectory(robot.coordinates, np.array([0.0, 0.01]), q, q, q, np.zeros((2, 3)),
                           actuators=robot.actuators, tau=tau)
    efforts = ros2.joint_efforts(robot, tr)
    assert efforts is not None and robot.coordinates[3] == "psi"
    steer = robot.actuators.index("steer")
    np.testing.assert_array_equal(efforts[:, 0], tau[:, steer])
    np.testing.assert_array_equal(efforts[:, 1:], tau[:, 2:])  # the arm's own efforts


def test_bag_is_written_completely_or_not_at_all(plan_dir: Path, tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("rosbags", reason="rosbags not installed (pip install 'mmplan[ros]')")

    def full_disk(new: Path, out: Path) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(ros2, "_replace_bag", full_disk)
    with pytest.raises(InputError, match="No space left"):
        export_plan(plan_dir, ros2=tmp_path / "bag")
    assert list(tmp_path.iterdir()) == []  # neither the bag nor a temporary folder


def test_bag_replaces_an_earlier_bag_but_nothing_else(plan_dir: Path, tmp_path: Path) -> None:
    pytest.importorskip("rosbags", reason="rosbags not installed (pip install 'mmplan[ros]')")
    export_plan(plan_dir, rate=50, ros2=tmp_path / "bag")
    done = export_plan(plan_dir, rate=RATE, ros2=tmp_path / "bag")
    assert done.bag is not None
    assert len(_read_bag(tmp_path / "bag")["/cmd_vel"]) == done.bag.points
    other = tmp_path / "notes"
    other.mkdir()
    (other / "a.txt").write_text("mine")
    with pytest.raises(InputError, match="not a rosbag2 folder"):
        export_plan(plan_dir, ros2=other)
    assert (other / "a.txt").read_text() == "mine"


def test_humble_and_jazzy_define_the_messages_alike() -> None:
    """The bag uses Humble's definitions; Jazzy's are identical (same RIHS01 hashes)."""
    pytest.importorskip("rosbags", reason="rosbags not installed (pip install 'mmplan[ros]')")
    from rosbags.typesys import Stores, get_typestore

    humble, jazzy = get_typestore(Stores.ROS2_HUMBLE), get_typestore(Stores.ROS2_JAZZY)
    for msgtype in ("trajectory_msgs/msg/JointTrajectory", "geometry_msgs/msg/Twist",
                    "nav_msgs/msg/Path"):
        assert humble.hash_rihs01(msgtype) == jazzy.hash_rihs01(msgtype)
