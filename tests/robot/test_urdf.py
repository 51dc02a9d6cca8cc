"""URDF import: the youbot-3r arm written as URDF must reproduce the built-in youbot-3r."""

from __future__ import annotations

import numpy as np
import pytest

from mmplan.errors import InputError
from mmplan.robot import get_robot
from mmplan.robot.library import youbot_3r as yb
from mmplan.robot.urdf import robot_from_urdf


def _rod(mass: float, length: float, com: tuple[float, float, float]) -> str:
    i = mass * length**2 / 12
    return (
        f'<inertial><origin xyz="{com[0]} {com[1]} {com[2]}"/><mass value="{mass}"/>'
        f'<inertia ixx="0" iyy="{i}" izz="{i}" ixy="0" ixz="0" iyz="0"/></inertial>'
    )


def youbot_arm_urdf() -> str:
    rise = yb.SHOULDER_HEIGHT - yb.MOUNT[2]
    deg = np.pi / 180
    return f"""<robot name="youbot_arm">
  <link name="arm_base"><inertial><mass value="0.961"/>
    <inertia ixx="0" iyy="0" izz="0" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="link1">{_rod(1.39, yb.L1, (yb.L1 / 2, 0, rise))}</link>
  <link name="link2">{_rod(1.318, yb.L2, (yb.L2 / 2, 0, 0))}</link>
  <link name="link3">{_rod(2.496, yb.L3, (yb.L3 / 2, 0, 0))}</link>
  <link name="tool"/>
  <joint name="q1" type="revolute"><parent link="arm_base"/><child link="link1"/>
    <axis xyz="0 0 -1"/><limit lower="{-169 * deg}" upper="{169 * deg}" effort="1" velocity="1"/>
  </joint>
  <joint name="q2" type="revolute"><parent link="link1"/><child link="link2"/>
    <origin xyz="{yb.L1} 0 {rise}"/><axis xyz="0 1 0"/>
    <limit lower="{-65 * deg}" upper="{90 * deg}" effort="10" velocity="1"/></joint>
  <joint name="q3" type="revolute"><parent link="link2"/><child link="link3"/>
    <origin xyz="{yb.L2} 0 0"/><axis xyz="0 1 0"/>
    <limit lower="{-151 * deg}" upper="{145 * deg}" effort="5" velocity="1"/></joint>
  <joint name="tool_joint" type="fixed"><parent link="link3"/><child link="tool"/>
    <origin xyz="{yb.L3} 0 0"/></joint>
</robot>"""


def _urdf_youbot():  # type: ignore[no-untyped-def]
    builtin = get_robot("youbot-3r")
    return builtin, robot_from_urdf(
        youbot_arm_urdf(), builtin.platform, "tool", name="youbot-urdf", mount_xyz=yb.MOUNT
    )


def test_urdf_arm_reproduces_builtin_kinematics_and_dynamics(rng: np.random.Generator) -> None:
    builtin, robot = _urdf_youbot()
    assert robot.coordinates == builtin.coordinates
    for _ in range(20):
        q, dq = rng.uniform(-2, 2, 8), rng.uniform(-2, 2, 8)
        np.testing.assert_allclose(robot.ee_position(q), builtin.ee_position(q), atol=1e-12)
        np.testing.assert_allclose(robot.mass_matrix(q), builtin.mass_matrix(q), atol=1e-10)
        np.testing.assert_allclose(robot.bias(q, dq), builtin.bias(q, dq), atol=1e-10)


def test_urdf_limits_come_from_the_file() -> None:
    builtin, robot = _urdf_youbot()
    np.testing.assert_allclose(robot.limits.joint_min, builtin.limits.joint_min)
    np.testing.assert_allclose(robot.limits.joint_max, builtin.limits.joint_max)
    np.testing.assert_allclose(robot.limits.torque_max[2:], [1.0, 10.0, 5.0])
    assert len(robot.collision) > 5


def test_urdf_errors_name_the_field() -> None:
    builtin = get_robot("youbot-3r")
    with pytest.raises(InputError, match=r"robot\.ee_link"):
        robot_from_urdf(youbot_arm_urdf(), builtin.platform, "gripper")
    with pytest.raises(InputError, match=r"robot\.urdf"):
        robot_from_urdf("/no/such/file.urdf", builtin.platform, "tool")
    with pytest.raises(InputError, match=r"robot\.urdf"):
        robot_from_urdf("<robot name='x'><link></robot>", builtin.platform, "tool")
