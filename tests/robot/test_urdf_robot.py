"""Whole-robot URDFs as they are (TIAGo, TIAGo dual, UR5 on a box), against Pinocchio.

Skipped, with the reason shown, where example-robot-data (extra ``robots``) is missing.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pinocchio as pin
import pytest

from mmplan.errors import InputError
from mmplan.robot import get_robot
from mmplan.robot.urdf import UrdfRobot, load_urdf_robot
from tests.robot.urdf_oracle import Oracle, build_oracle, robot_data_dir

TOL = 1e-9
WHEELS = ["wheel_left_joint", "wheel_right_joint"]
DIFF = {"kind": "differential-drive", "wheels": WHEELS}
TIAGO_Q = ("x", "y", "theta", "wheel_left_joint", "wheel_right_joint", "torso_lift_joint",
           *(f"arm_{i}_joint" for i in range(1, 8)))


def tiago_urdf(name: str = "tiago") -> str:
    return str(robot_data_dir() / "tiago_description" / "robots" / f"{name}.urdf")


@pytest.fixture(scope="module")
def tiago() -> UrdfRobot:
    robot_data_dir()  # skips without example-robot-data
    robot = get_robot("tiago")
    assert isinstance(robot, UrdfRobot)
    return robot


def random_q(robot: UrdfRobot, rng: np.random.Generator) -> np.ndarray:
    """Platform pose and wheels anywhere, arm joints inside their limits."""
    q = rng.uniform(-3, 3, robot.n)
    lo = np.maximum(robot.limits.joint_min, -3)
    hi = np.minimum(robot.limits.joint_max, 3)
    q[robot.n_platform :] = rng.uniform(lo, hi)
    return q


def assert_agrees_with_pinocchio(
    robot: UrdfRobot, oracle: Oracle, rng: np.random.Generator, frame: str, samples: int = 20
) -> dict[str, float]:
    """FK of every body and the end-effector frame, CRBA and RNEA, to TOL; the worst errors."""
    s = robot.symbols
    names = list(robot.coordinates[3:])  # every URDF joint that moves: its body's frame
    bodies = [j.child for j in robot.tree.joints if j.coordinate in names]
    names = [j.coordinate for j in robot.tree.joints if j.coordinate in names]
    fk = ca.Function("fk", [s.q], [ca.vertcat(*[s.transforms[b] for b in bodies])])
    model, data, vi = oracle.model, oracle.data, oracle.v_index
    fid = model.getFrameId(frame)
    worst = {"fk": 0.0, "ee": 0.0, "M": 0.0, "rnea": 0.0}
    for _ in range(samples):
        q, dq, ddq = random_q(robot, rng), rng.uniform(-2, 2, robot.n), rng.uniform(-2, 2, robot.n)
        qp = oracle.q(q)
        v, a = np.zeros(model.nv), np.zeros(model.nv)
        v[vi], a[vi] = dq, ddq
        pin.framesForwardKinematics(model, data, qp)
        T = np.asarray(fk(q)).reshape(len(bodies), 4, 4)
        for k, name in enumerate(names):
            err = np.abs(T[k] - data.oMi[model.getJointId(name)].homogeneous).max()
            worst["fk"] = max(worst["fk"], float(err))
        ee_err = np.abs(robot.ee_position(q) - data.oMf[fid].translation).max()
        worst["ee"] = max(worst["ee"], float(ee_err))
        M_pin = pin.crba(model, data, qp)
        M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T
        worst["M"] = max(worst["M"], float(np.abs(robot.mass_matrix(q) - M_pin[np.ix_(vi, vi)]
                                                  ).max()))
        tau_pin = pin.rnea(model, data, qp, v, a)[vi]
        tau = robot.mass_matrix(q) @ ddq + robot.bias(q, dq)
        worst["rnea"] = max(worst["rnea"], float(np.abs(tau - tau_pin).max()))
    for key, value in worst.items():
        assert value < TOL, (key, value)
    return worst


def test_tiago_loads_unmodified_with_its_coordinates(tiago: UrdfRobot) -> None:
    assert tiago.coordinates == TIAGO_Q
    assert (tiago.n, tiago.h, tiago.n_platform) == (13, 3, 5)
    assert tiago.actuators == TIAGO_Q[3:]
    assert tiago.source.chain == TIAGO_Q[5:]
    assert {"head_1_joint", "head_2_joint", "hand_thumb_joint"} <= set(tiago.source.held)


def test_tiago_wheel_radius_and_track_are_derived_from_the_urdf(tiago: UrdfRobot) -> None:
    platform = tiago.platform
    assert platform.wheel_radius == pytest.approx(0.0985, abs=1e-12)  # type: ignore[attr-defined]
    assert platform.half_track == pytest.approx(0.2022, abs=1e-12)  # type: ignore[attr-defined]
    assert "collision cylinder" in tiago.source.derived["wheel_radius"][1]
    assert "origins" in tiago.source.derived["half_track"][1]
    # rolling: both wheels at 1 rad/s drive the base forward at r m/s, no yaw
    q = np.zeros(tiago.n)
    N = tiago.null_basis(q)
    dq = N[:, :2] @ [1.0, 1.0]
    np.testing.assert_allclose(dq[:3], [0.0985, 0, 0], atol=1e-15)
    np.testing.assert_allclose(tiago.pfaffian(q) @ dq, 0, atol=1e-15)


def test_tiago_limits_efforts_and_rates_come_from_the_urdf(tiago: UrdfRobot) -> None:
    lim = tiago.limits
    i_torso, i_arm1 = 0, 1  # arm coordinates: torso_lift_joint, arm_1_joint, ...
    assert (lim.joint_min[i_torso], lim.joint_max[i_torso]) == (0.0, 0.35)
    assert lim.joint_min[i_arm1] == 0.0
    assert lim.joint_max[i_arm1] == pytest.approx(2.74889357189)
    np.testing.assert_allclose(lim.torque_max[:4], [6.0, 6.0, 2000.0, 39.0])
    np.testing.assert_allclose(lim.torque_min, -lim.torque_max)
    assert lim.rates.velocity["torso_lift_joint"] == 0.07
    assert lim.rates.velocity["arm_1_joint"] == 2.7
    assert lim.rates.velocity["wheel_left_joint"] == pytest.approx(10.152284264)
    assert "URDF" in lim.rates.sources["velocity.arm_7_joint"]


def test_tiago_agrees_with_pinocchio(tiago: UrdfRobot, rng: np.random.Generator) -> None:
    oracle = build_oracle(tiago, tiago_urdf())
    worst = assert_agrees_with_pinocchio(tiago, oracle, rng, "arm_tool_link")
    print("tiago vs Pinocchio, worst abs. errors:", worst)


def test_tiago_end_effector_at_arm_7_link_with_an_offset(rng: np.random.Generator) -> None:
    robot = load_urdf_robot(tiago_urdf(), platform=DIFF, end_effector="arm_7_link",
                            ee_offset=(0.0, 0.0, 0.1), collision=None)
    oracle = build_oracle(robot, tiago_urdf())
    fid = oracle.model.getFrameId("arm_7_link")
    for _ in range(5):
        q = random_q(robot, rng)
        pin.framesForwardKinematics(oracle.model, oracle.data, oracle.q(q))
        expected = oracle.data.oMf[fid].act(np.array([0.0, 0.0, 0.1]))
        np.testing.assert_allclose(robot.ee_position(q), expected, atol=TOL)


def test_locked_joints_hold_their_values(rng: np.random.Generator) -> None:
    locked = {"torso_lift_joint": 0.2, "arm_7_joint": 0.5, "head_1_joint": -0.4}
    robot = load_urdf_robot(tiago_urdf(), platform=DIFF, end_effector="arm_tool_link",
                            locked=locked, collision=None)
    assert "torso_lift_joint" not in robot.coordinates
    assert "arm_7_joint" not in robot.coordinates
    assert robot.coordinates[-1] == "arm_6_joint"
    assert robot.source.held["torso_lift_joint"] == 0.2
    assert robot.source.held["head_1_joint"] == -0.4
    oracle = build_oracle(robot, tiago_urdf())
    assert_agrees_with_pinocchio(robot, oracle, rng, "arm_tool_link", samples=5)
    # the torso held at 0.2 m: the tool is 0.2 m higher than with the torso at 0
    free = load_urdf_robot(tiago_urdf(), platform=DIFF, end_effector="arm_tool_link",
                           locked={"arm_7_joint": 0.5}, collision=None)
    q = np.zeros(robot.n)
    q_free = np.insert(q, 5, 0.0)
    np.testing.assert_allclose(robot.ee_position(q) - free.ee_position(q_free), [0, 0, 0.2],
                               atol=1e-12)


def test_tiago_dual_loads_with_one_arm_moving(rng: np.random.Generator) -> None:
    robot = load_urdf_robot(tiago_urdf("tiago_dual"), platform=DIFF,
                            end_effector="arm_right_tool_link", collision=None)
    assert robot.coordinates == ("x", "y", "theta", *WHEELS, "torso_lift_joint",
                                 *(f"arm_right_{i}_joint" for i in range(1, 8)))
    held = robot.source.held
    assert len(held) == 101 - 10  # every other joint of the 101 (111 configuration variables)
    assert held["suspension_left_joint"] == 0.0 and "arm_left_3_joint" in held
    assert held["arm_left_1_joint"] == 0.0
    oracle = build_oracle(robot, tiago_urdf("tiago_dual"))
    assert_agrees_with_pinocchio(robot, oracle, rng, "arm_right_tool_link", samples=5)


def test_ur5_on_a_box_platform_agrees_with_pinocchio(rng: np.random.Generator) -> None:
    from mmplan.robot.library import ur5_omni

    urdf = robot_data_dir() / ur5_omni.URDF
    robot = get_robot("ur5-omni")
    assert isinstance(robot, UrdfRobot)
    assert robot.coordinates[3:] == ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                                     "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")
    mount = pin.SE3(np.eye(3), np.array(ur5_omni.MOUNT_XYZ))
    size = ur5_omni.BOX_SIZE
    box = (ur5_omni.BOX_MASS, size, (0.0, 0.0, size[2] / 2))
    oracle = build_oracle(robot, urdf, mount, box)
    worst = assert_agrees_with_pinocchio(robot, oracle, rng, "tool0")
    print("ur5-omni vs Pinocchio, worst abs. errors:", worst)
    assert robot.limits.torque_max[3:].tolist() == [150.0, 150.0, 150.0, 28.0, 28.0, 28.0]
    # the SRDF exempts base_link (the platform) / upper_arm_link
    assert ("platform", "upper_arm_link") not in robot.self_collision.body_pairs


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"end_effector": "arm_8_link"}, r"robot\.end_effector: unknown frame 'arm_8_link'; close "
                                     r"matches: arm_\d_link"),
    ({"end_effector": "base_link"}, r"'base_link' is fixed to the URDF root"),
    ({"platform": {"kind": "differential-drive", "wheels": ["wheel_left_joint", "arm_1_joint"]}},
     r"wheels\[1\]: wheel joint 'arm_1_joint' is revolute, not continuous"),
    ({"platform": {"kind": "differential-drive", "wheels": ["wheel_left_joint", "wheel_rigth"]}},
     r"wheels\[1\]: unknown wheel joint 'wheel_rigth'; close matches: wheel_right_joint"),
    ({"platform": {"kind": "differential-drive", "wheels": WHEELS[::-1]}},
     r"list the left wheel \(\+y\) first"),
    ({"platform": {"kind": "differential-drive", "wheels": WHEELS[:1]}}, r"two distinct"),
    ({"platform": {"kind": "tracked"}}, r"robot\.platform\.kind: unknown kind 'tracked'"),
    ({"locked": {"torso_lift_joint": 0.5}},
     r"robot\.locked\.torso_lift_joint: locked value 0\.5 outside the joint's limits \[0, 0\.35\]"),
    ({"locked": {"torso_lift": 0.1}}, r"unknown joint 'torso_lift'; close matches: torso_lift_"),
    ({"locked": {"wheel_left_joint": 0.0}}, r"wheel joint of the platform cannot be locked"),
    ({"mount": {"xyz": [0, 0, 0.1]}}, r"robot\.platform\.box: missing"),
    ({"platform": {**DIFF, "box": {"size": [1, 1, 1], "mass": 1}}}, r"only for an arm-only"),
])
def test_errors_name_the_joint_or_frame(kwargs: dict, match: str) -> None:
    args = {"platform": DIFF, "end_effector": "arm_tool_link", "collision": None, **kwargs}
    with pytest.raises(InputError, match=match) as info:
        load_urdf_robot(tiago_urdf(), **args)
    assert "\n" not in str(info.value)


def test_a_continuous_arm_joint_in_the_old_arm_only_path_is_named() -> None:
    from mmplan.robot.urdf import robot_from_urdf

    with pytest.raises(InputError, match=r"joint 'wheel_left_joint' is continuous"):
        robot_from_urdf(tiago_urdf(), get_robot("youbot-3r").platform, "arm_tool_link")
