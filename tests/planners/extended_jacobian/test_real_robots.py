"""The extended-Jacobian planner on real robots (TIAGo, UR5 on an omnidirectional base):
the causes found and fixed (docs/extended_jacobian.md, Real robots), one test each, and the
built-in scenarios end to end. Skipped without example-robot-data.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np
import pytest
from click.testing import CliRunner

from mmplan.cli.main import main
from mmplan.planners.extended_jacobian import divergence
from mmplan.planners.extended_jacobian.criterion import (
    Partition,
    build_criterion,
    choose_partition,
)
from mmplan.planners.extended_jacobian.near_goal import fade_at_limits
from mmplan.planners.extended_jacobian.obstacles import ObstacleTerm, obstacle_penalty
from mmplan.planners.extended_jacobian.options import RolloutOptions
from mmplan.planners.extended_jacobian.planner import ExtendedJacobian
from mmplan.planners.extended_jacobian.posture import heading_reference, posture_weights
from mmplan.planners.extended_jacobian.settings import ExtendedJacobianSettings
from mmplan.planners.extended_jacobian.wrist import find_wrist, wrist_jacobian
from mmplan.robot.library import get_robot
from mmplan.robot.robot import Robot
from mmplan.scenario.loader import Scenario
from mmplan.scene.sphere import Sphere
from mmplan.trajectory import Status
from tests.planners.extended_jacobian.tiago_scenes import START as TIAGO_START
from tests.robot.urdf_oracle import robot_data_dir

UR5_START = [0.0, 0.0, 0.0, 0.0, -1.2, 1.5, -1.0, -1.57, 0.0]
Q0_3R = np.array([0.0, -0.5, np.pi / 2, 0.0, 0.0, 0.0, -0.17, 0.35])


@pytest.fixture(scope="module")
def tiago() -> Robot:
    robot_data_dir()  # skips without example-robot-data
    return get_robot("tiago")


@pytest.fixture(scope="module")
def ur5() -> Robot:
    robot_data_dir()
    return get_robot("ur5-omni")


def _names(robot: Robot, indices: tuple[int, ...]) -> list[str]:
    return [robot.coordinates[i] for i in indices]


def test_wrist_centre_is_where_the_wrist_axes_meet(tiago: Robot, ur5: Robot) -> None:
    """TIAGo: arm_5..7 meet at arm_6's origin; UR5: wrist_2 and wrist_3; the papers' youBots
    have no wrist. The wrist joints do not move W (their columns of dW/dq are left out)."""
    wrist = find_wrist(tiago)
    assert wrist is not None and _names(tiago, wrist.joints) == [
        "arm_5_joint", "arm_6_joint", "arm_7_joint"]
    s = tiago.symbols
    T = s.transforms[wrist.body]
    W = ca.Function("W", [s.q], [T[:3, :3] @ ca.DM(wrist.offset) + T[:3, 3]])
    origin = ca.Function("o", [s.q], [s.transforms["arm_6_link"][:3, 3]])
    dW = ca.Function("dW", [s.q], [ca.jacobian(W(s.q), s.q)])
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = np.asarray(TIAGO_START) + rng.uniform(-0.3, 0.3, tiago.n)
        np.testing.assert_allclose(np.asarray(W(q)).ravel(), np.asarray(origin(q)).ravel(),
                                   atol=1e-9)
        assert np.abs(np.asarray(dW(q))[:, list(wrist.joints)]).max() < 1e-12
    assert wrist_jacobian(tiago, wrist).shape == (3, 5)  # torso and arm_1..4 position W
    ur5_wrist = find_wrist(ur5)
    assert ur5_wrist is not None
    assert _names(ur5, ur5_wrist.joints) == ["wrist_2_joint", "wrist_3_joint"]
    for name in ("youbot-3r", "youbot-4r"):
        assert find_wrist(get_robot(name)) is None


def test_posture_weights_leave_the_papers_robots_alone(tiago: Robot, ur5: Robot) -> None:
    """Posture term: every TIAGo arm joint, the UR5's wrist joints, no youBot joint."""
    np.testing.assert_array_equal(posture_weights(tiago), np.ones(8))
    np.testing.assert_array_equal(posture_weights(ur5), [0, 0, 0, 0, 1, 1])
    for name in ("youbot-3r", "youbot-4r"):
        assert not np.any(posture_weights(get_robot(name)))
    np.testing.assert_array_equal(posture_weights(tiago, 0.5), np.full(8, 0.5))


def test_partition_prefers_revolute_joints_and_handles_an_omni_base(
    tiago: Robot, ur5: Robot
) -> None:
    """TIAGo: arm_2 rather than the (better conditioned) torso in R; ur5-omni: x, y and a
    joint that moves the tool vertically (x, y, theta alone are singular); youbot-3r: the
    [RefRuns] partition."""
    part = choose_partition(tiago, np.asarray(TIAGO_START))
    assert _names(tiago, part.R) == ["x", "y", "theta", "wheel_left_joint",
                                     "wheel_right_joint", "arm_2_joint"]
    part = choose_partition(ur5, np.asarray(UR5_START))
    assert _names(ur5, part.R) == ["x", "y", "shoulder_lift_joint"]
    youbot = get_robot("youbot-3r")
    assert _names(youbot, choose_partition(youbot, Q0_3R).R) == [
        "x", "y", "theta", "phi1", "phi2", "q2"]


def _cond_E(robot: Robot, part: Partition, q0: np.ndarray, p_f: np.ndarray, **kw: Any) -> float:
    crit = build_criterion(robot, part, 0.01, posture=posture_weights(robot), **kw)
    E = ca.Function("E", [crit.q, crit.p_f], [crit.E])
    return float(np.linalg.cond(np.asarray(E(q0, p_f))))


def test_heading_term_makes_E_regular_on_an_omni_base(ur5: Robot) -> None:
    """Turning the whole robot about the end effector leaves mu and the arm's terms
    unchanged: without a heading term E is singular at every state."""
    q0, p_f = np.asarray(UR5_START), np.array([2.0, 1.0, 0.8])
    part = choose_partition(ur5, q0)
    assert _cond_E(ur5, part, q0, p_f) > 1e12
    theta_ref = heading_reference(ur5, q0, p_f)
    assert theta_ref == pytest.approx(np.arctan2(1.0, 2.0))
    assert _cond_E(ur5, part, q0, p_f, heading=theta_ref) < 1e5
    assert heading_reference(get_robot("youbot-3r"), Q0_3R, p_f) is None


def test_sphere_radii_enter_the_obstacle_distance() -> None:
    """A sphere of radius r at radial distance C + r weighs like a point at C."""
    model = Sphere((0.0, 0.0, 0.0), 0.3).superellipsoid()
    obstacle = ObstacleTerm(model, 0.2)
    points = ca.SX(ca.DM([[0.45, 0.0], [0.0, 0.55], [0.0, 0.0]]))  # radial distances 0.15, 0.25
    def value(expr: ca.SX) -> float:
        return float(ca.evalf(expr))

    with_radii = value(obstacle_penalty(points, [obstacle], radii=np.array([0.1, 0.1])))
    shifted = ca.SX(ca.DM([[0.35, 0.0], [0.0, 0.45], [0.0, 0.0]]))
    as_points = value(obstacle_penalty(shifted, [obstacle]))
    assert with_radii == pytest.approx(as_points) and with_radii > 0.0
    assert value(obstacle_penalty(points, [obstacle])) < with_radii


def test_joint_limit_fade_spans_a_fraction_of_a_short_range() -> None:
    """A prismatic joint of 0.35 m range fades within 0.105 m of its limit, not 0.2."""
    q = ca.SX.sym("q", 1)
    fp = ca.SX.sym("fp", 1)
    fn = ca.Function("f", [q, fp], [fade_at_limits(fp, q, [0], np.array([0.0]),
                                                   np.array([0.35]))])
    assert float(fn(0.2, 1.0)) == pytest.approx(1.0)  # 0.15 m from the upper limit: free
    assert 0.0 < float(fn(0.3, 1.0)) < 1.0
    wide = ca.Function("g", [q, fp], [fade_at_limits(fp, q, [0], np.array([-3.0]),
                                                     np.array([3.0]))])
    assert float(wide(2.85, 1.0)) == pytest.approx(1.0 - 0.0, abs=0.2) and float(
        wide(2.9, 1.0)) < 1.0  # youBot-like ranges: the 0.2 rad margin as before


def test_stall_verdict_is_relative_to_the_error() -> None:
    """1 mm/window is no stall when the error itself is a few mm and falling by > 10 %."""
    settings = ExtendedJacobianSettings.model_validate({})
    opt = RolloutOptions.from_settings(settings, get_robot("youbot-3r"), 1e-3)
    assert not opt.stalled(0.0036, 0.003)  # -17 %: converging
    assert opt.stalled(0.3, 0.2995)  # 0.5 mm of 0.3 m: stalled
    assert not opt.stalled(0.3, 0.29)


def test_divergence_guard_units() -> None:
    """Insane samples, the blow-up's onset and the message."""
    dq = np.zeros((6, 2))
    ddq = np.array([[1.0, 0], [1.2, 0], [0.9, 0], [30.0, 0], [900.0, 0], [2e4, 0]])
    bad = divergence.insane(dq, ddq)
    np.testing.assert_array_equal(bad, [False] * 5 + [True])
    assert divergence.onset(ddq, 5) == 3  # 30 and 900 rad/s^2 belong to the blow-up
    text = divergence.message(2.3, dq[5], ddq[5], ("a", "b"), 4e3)
    assert "diverged at t = 2.300 s" in text and "|ddq| of a" in text and "cond(E)" in text
    assert divergence.insane(np.array([np.nan, 0.0]), np.zeros(2))[0]


def test_a_diverging_plan_says_so_and_keeps_finite_samples(tiago: Robot) -> None:
    """Without the posture term (beta = 0) TIAGo's generator meets an algorithmic singularity;
    the plan ends ``diverged`` with time and cause, no exception, no blow-up samples."""
    data = {
        "name": "diverging", "robot": "tiago", "start": TIAGO_START,
        "goal": {"position": [0.97, -1.1, 0.79], "tolerance": 0.001},
        "limits": {"torque": "unlimited"},
        "planner": {"method": "extended-jacobian", "posture_weight": 0.0, "t_max": 15,
                    "dt": 0.02},
    }  # fmt: skip
    problem = Scenario.from_dict(data, "diverging").build()
    result = ExtendedJacobian().plan(problem)
    assert result.status is Status.DIVERGED, result.message
    assert "diverged at t = " in result.message
    tr = result.trajectory
    assert tr.is_finite() and len(tr.t) > 10
    assert float(np.abs(tr.ddq).max()) < 100.0


@pytest.mark.parametrize("name", ["tiago-table", "tiago-shelf", "ur5-omni-table"])
def test_builtin_scenario_reaches_and_passes_the_check(name: str, tmp_path: Path) -> None:
    """``mmplan plan NAME --out D && mmplan check D`` exit 0."""
    robot_data_dir()
    out = tmp_path / name
    runner = CliRunner()
    planned = runner.invoke(main, ["plan", name, "--out", str(out), "--quiet"])
    assert planned.exit_code == 0, planned.output
    checked = runner.invoke(main, ["check", str(out)])
    assert checked.exit_code == 0, checked.output


@pytest.mark.parametrize("scenario", ["youbot3r-obstacles-torque", "youbot4r-reach",
                                      "tiago-table", "ur5-omni-table"])  # fmt: skip
def test_rows_of_E_are_the_stacked_jacobian(scenario: str) -> None:
    """The partition switch reads Jc = [J; A] off the generator's E = [de_I/dq; A] (first
    three rows and last h rows, :mod:`...switching`): equal to the robot's own J and A at
    random configurations near the start."""
    from mmplan.planners.extended_jacobian.criterion import stacked_jacobian
    from mmplan.scenario.loader import load_scenario

    problem = load_scenario(scenario).build()
    if scenario.startswith(("tiago", "ur5")):
        robot_data_dir()
    prep = ExtendedJacobian._prepare(problem)
    robot, rng = problem.robot, np.random.default_rng(4)
    for _ in range(5):
        q = prep.q0 + rng.normal(0.0, 0.2, robot.n)
        E = np.asarray(prep.fns.E(q, prep.params), dtype=float)
        h = robot.h
        from_E = np.vstack([E[:3], E[len(E) - h :]]) if h else E[:3]
        np.testing.assert_allclose(from_E, stacked_jacobian(robot, q), rtol=1e-12, atol=1e-12)
