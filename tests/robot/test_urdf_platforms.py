"""Platforms of URDF robots: wheels placed anywhere on one axle roll without slipping; arm-only
URDFs on a box (rotated mounts, synthetic wheels); URDF text; errors."""

from __future__ import annotations

from pathlib import Path

import casadi as ca
import numpy as np
import pinocchio as pin
import pytest

from mmplan.errors import InputError
from mmplan.robot.urdf import UrdfRobot, load_urdf_robot
from tests.robot.test_urdf_robot import assert_agrees_with_pinocchio
from tests.robot.urdf_oracle import build_oracle, robot_data_dir

R_WHEEL = 0.08


def _inertial(mass: float, xyz: str = "0 0 0") -> str:
    return (f'<inertial><origin xyz="{xyz}"/><mass value="{mass}"/><inertia ixx="0.02" '
            'iyy="0.03" izz="0.04" ixy="0.001" ixz="0.002" iyz="0.003"/></inertial>')


def cart_urdf(lift: float = 0.0, right_x: float = -0.1) -> str:
    """A cart: wheels on an axle 0.1 m behind the root, at y = +0.25 and -0.22, the right
    wheel's axis along -y; a passive caster; a 2-joint arm with a tip frame."""
    wheel = (f'<collision><geometry><cylinder radius="{R_WHEEL}" length="0.03"/></geometry>'
             "</collision>")
    return f"""<robot name="cart">
  <link name="base_footprint"/>
  <link name="base_link">{_inertial(10, "0.05 0 0.1")}
    <collision><origin xyz="0 0 0.15"/><geometry><box size="0.5 0.4 0.2"/></geometry></collision>
  </link>
  <joint name="base_joint" type="fixed"><parent link="base_footprint"/><child link="base_link"/>
    <origin xyz="0 0 {lift}"/></joint>
  <link name="wheel_l">{_inertial(1.0)}{wheel}</link>
  <link name="wheel_r">{_inertial(1.1)}{wheel}</link>
  <joint name="left" type="continuous"><parent link="base_link"/><child link="wheel_l"/>
    <origin xyz="-0.1 0.25 {R_WHEEL}" rpy="-1.5707963267948966 0 0"/><axis xyz="0 0 1"/>
    <limit effort="5" velocity="12"/></joint>
  <joint name="right" type="continuous"><parent link="base_link"/><child link="wheel_r"/>
    <origin xyz="{right_x} -0.22 {R_WHEEL}" rpy="1.5707963267948966 0 0"/><axis xyz="0 0 1"/>
    <limit effort="5" velocity="12"/></joint>
  <link name="caster">{_inertial(0.3)}</link>
  <joint name="caster_joint" type="continuous"><parent link="base_link"/><child link="caster"/>
    <origin xyz="0.2 0 0.03"/><axis xyz="0 0 1"/></joint>
  <link name="l1">{_inertial(2, "0 0 0.1")}</link>
  <link name="l2">{_inertial(1, "0.15 0 0")}
    <collision><origin xyz="0.15 0 0" rpy="0 1.5707963267948966 0"/>
      <geometry><cylinder radius="0.03" length="0.3"/></geometry></collision></link>
  <link name="tip"/>
  <joint name="j1" type="revolute"><parent link="base_link"/><child link="l1"/>
    <origin xyz="0.1 0 0.25"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" effort="20" velocity="1.5"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0 0 0.3" rpy="0.1 0.2 0.3"/><axis xyz="0 0.6 0.8"/>
    <limit lower="-1" upper="1.5" effort="10" velocity="2"/></joint>
  <joint name="tip_joint" type="fixed"><parent link="l2"/><child link="tip"/>
    <origin xyz="0.3 0 0"/></joint>
</robot>"""


CART = {"kind": "differential-drive", "wheels": ["left", "right"]}


def test_cart_from_urdf_text(rng: np.random.Generator, tmp_path: Path) -> None:
    robot = load_urdf_robot(cart_urdf(), platform=CART, end_effector="tip")
    assert robot.coordinates == ("x", "y", "theta", "left", "right", "j1", "j2")
    assert robot.source.held == {"caster_joint": 0.0} and robot.source.urdf is None
    platform = robot.platform
    assert platform.wheel_radius == R_WHEEL  # type: ignore[attr-defined]
    assert platform.lateral == (0.25, -0.22)  # type: ignore[attr-defined]
    assert platform.axle_x == pytest.approx(-0.1)  # type: ignore[attr-defined]
    assert platform.signs == (1.0, -1.0)  # type: ignore[attr-defined]
    assert {s.body for s in robot.collision} == {"platform", "wheel_l", "wheel_r", "l2"}
    path = tmp_path / "cart.urdf"
    path.write_text(cart_urdf())
    assert_agrees_with_pinocchio(robot, build_oracle(robot, path), rng, "tip", samples=10)


def test_cart_wheels_roll_without_slipping(rng: np.random.Generator) -> None:
    """For dq in ker A, each wheel's material point touching the ground has zero velocity."""
    robot = load_urdf_robot(cart_urdf(), platform=CART, end_effector="tip", collision=None)
    s = robot.symbols
    T = {w: ca.Function(w, [s.q], [s.transforms[w]]) for w in ("wheel_l", "wheel_r")}
    h = 1e-6
    for _ in range(10):
        q = rng.uniform(-2, 2, robot.n)
        dq = robot.null_basis(q) @ rng.uniform(-1, 1, robot.n - robot.h)
        np.testing.assert_allclose(robot.pfaffian(q) @ dq, 0, atol=1e-14)
        for fn in T.values():
            Tw = np.asarray(fn(q))
            contact = Tw[:3, 3] - [0, 0, R_WHEEL]  # the lowest point of the wheel
            local = np.linalg.solve(Tw, np.r_[contact, 1.0])  # the material point there
            v = (np.asarray(fn(q + h * dq)) @ local - np.asarray(fn(q - h * dq)) @ local) / (2 * h)
            np.testing.assert_allclose(v[:3], 0, atol=1e-8)


def test_arm_only_urdf_on_a_rotated_mount(rng: np.random.Generator) -> None:
    urdf = robot_data_dir() / "ur_description" / "urdf" / "ur5_robot.urdf"
    xyz, rpy = [0.1, -0.05, 0.35], [0.0, 0.2, 1.2]
    box = {"size": [0.6, 0.5, 0.35], "mass": 40.0, "center": [0.0, 0.02, 0.175]}
    robot = load_urdf_robot(urdf, platform={"kind": "omnidirectional", "box": box},
                            end_effector="tool0", mount={"xyz": xyz, "rpy": rpy}, collision=None)
    mount = pin.SE3(pin.rpy.rpyToMatrix(np.array(rpy)), np.array(xyz))
    oracle = build_oracle(robot, urdf, mount, (40.0, (0.6, 0.5, 0.35), (0.0, 0.02, 0.175)))
    assert_agrees_with_pinocchio(robot, oracle, rng, "tool0", samples=10)


def test_arm_only_urdf_on_a_differential_drive_with_new_wheels() -> None:
    urdf = robot_data_dir() / "ur_description" / "urdf" / "ur5_robot.urdf"
    platform = {"kind": "differential-drive", "wheels": ["phi_l", "phi_r"], "wheel_radius": 0.1,
                "half_track": 0.3, "box": {"size": [0.6, 0.5, 0.3], "mass": 30.0}}
    robot = load_urdf_robot(urdf, platform=platform, end_effector="tool0",
                            mount={"xyz": [0, 0, 0.3]}, collision=None)
    assert robot.coordinates[:5] == ("x", "y", "theta", "phi_l", "phi_r")
    assert robot.h == 3 and robot.source.derived["wheel_radius"] == (0.1, "given")
    q = np.linspace(-1, 1, robot.n)
    np.testing.assert_allclose(robot.pfaffian(q) @ robot.null_basis(q), 0, atol=1e-14)
    assert np.linalg.eigvalsh(robot.mass_matrix(q)).min() > 0


def test_unicycle_platform_holds_the_urdf_wheels() -> None:
    robot = load_urdf_robot(cart_urdf(), platform={"kind": "unicycle"}, end_effector="tip",
                            collision=None)
    assert robot.coordinates == ("x", "y", "phi", "j1", "j2") and robot.h == 1
    assert {"left", "right", "caster_joint"} <= set(robot.source.held)


@pytest.mark.parametrize(("urdf", "kwargs", "match"), [
    (cart_urdf(lift=0.05), {}, r"wheel 'left' has its centre 0\.13 m above the URDF root but "
                               r"radius 0\.08 m"),
    (cart_urdf(right_x=0.0), {}, r"the wheels are not on one axle \(x = -0\.1, 0\)"),
    (cart_urdf(), {"platform": {**CART, "wheels": ["left", "caster_joint"]}},
     r"wheel joint 'caster_joint': axis \[0\.0, 0\.0, 1\.0\] in the root frame is not along y"),
    (cart_urdf(), {"platform": {**CART, "wheels": ["left", "j1"]}}, r"'j1' is revolute"),
    (cart_urdf(), {"end_effector": "wheel_l"}, r"wheel joint 'left' carries the end effector"),
    (cart_urdf(), {"locked": {"j2": 2.0}}, r"locked\.j2: locked value 2 outside .*\[-1, 1\.5\]"),
    (cart_urdf(), {"locked": {"j1": 0.0, "j2": 0.0}}, r"every joint moving 'tip' is locked"),
    (cart_urdf(), {"platform": {"kind": "omnidirectional", "wheels": ["left"]}},
     r"omnidirectional platform has no wheel coordinates"),
    (cart_urdf(), {"platform": {**CART, "hub": 1}}, r"robot\.platform\.hub: unknown key"),
    (cart_urdf(), {"mount": {"xyz": [0, 0]}}, r"robot\.mount\.xyz: expected 3 finite numbers"),
    ("<robot name='x'><link></robot>", {}, r"robot\.urdf: cannot parse URDF"),
    ("/no/such.urdf", {}, r"robot\.urdf: no such file"),
])
def test_platform_errors(urdf: str, kwargs: dict, match: str) -> None:
    args = {"platform": CART, "end_effector": "tip", **kwargs}
    with pytest.raises(InputError, match=match) as info:
        load_urdf_robot(urdf, **args)
    assert "\n" not in str(info.value)


def test_arm_only_wheel_names_must_be_new() -> None:
    platform = {**CART, "wheel_radius": 0.1, "half_track": 0.2,
                "box": {"size": [0.5, 0.5, 0.2], "mass": 5}}
    with pytest.raises(InputError, match=r"wheels\[0\]: 'left' is a URDF joint"):
        load_urdf_robot(cart_urdf(), platform=platform, end_effector="tip", mount={})
    del platform["wheel_radius"]
    platform["wheels"] = ["a", "b"]
    with pytest.raises(InputError, match=r"wheel_radius: missing"):
        load_urdf_robot(cart_urdf(), platform=platform, end_effector="tip", mount={},
                        collision=None)


def test_robot_is_a_urdf_robot() -> None:
    robot = load_urdf_robot(cart_urdf(), platform=CART, end_effector="tip")
    assert isinstance(robot, UrdfRobot)
    assert robot.actuators == ("left", "right", "j1", "j2")
    np.testing.assert_allclose(robot.limits.torque_max, [5, 5, 20, 10])
    assert robot.limits.rates.velocity == {"left": 12, "right": 12, "j1": 1.5, "j2": 2}
