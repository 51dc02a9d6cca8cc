"""A small whole-robot URDF for tests that need no example-robot-data: a differential drive
(two continuous wheels), a head joint to hold, and a two-joint arm that can fold down into the
platform box (a self-collision).

Geometry (platform frame, metres): box 0.6 x 0.4 x 0.2 centred at z = 0.2 (top at 0.3); wheels
r = 0.1 at y = +-0.25, z = 0.1; ``joint1`` (about z) on the box top, ``link1`` a vertical
cylinder to z = 0.6; ``joint2`` (about y, limits [-2, 2]) at z = 0.6, ``link2`` a 0.5 m box
along x; frame ``tool`` at its end. ``joint2 = pi/2`` points link2 straight down into the box.
Efforts are 0 (unlimited); velocities 2 rad/s.
"""

from __future__ import annotations

from pathlib import Path

MINI_URDF = """<?xml version="1.0"?>
<robot name="mini">
  <link name="base_link">
    <inertial><origin xyz="0 0 0.2"/><mass value="20"/>
      <inertia ixx="0.3" ixy="0" ixz="0" iyy="0.6" iyz="0" izz="0.8"/></inertial>
    <collision><origin xyz="0 0 0.2"/><geometry><box size="0.6 0.4 0.2"/></geometry></collision>
  </link>
  <link name="wheel_left_link">
    <inertial><mass value="1"/>
      <inertia ixx="0.003" ixy="0" ixz="0" iyy="0.005" iyz="0" izz="0.003"/></inertial>
    <collision><origin rpy="1.5707963 0 0"/>
      <geometry><cylinder radius="0.1" length="0.04"/></geometry></collision>
  </link>
  <link name="wheel_right_link">
    <inertial><mass value="1"/>
      <inertia ixx="0.003" ixy="0" ixz="0" iyy="0.005" iyz="0" izz="0.003"/></inertial>
    <collision><origin rpy="1.5707963 0 0"/>
      <geometry><cylinder radius="0.1" length="0.04"/></geometry></collision>
  </link>
  <joint name="wheel_left_joint" type="continuous">
    <parent link="base_link"/><child link="wheel_left_link"/>
    <origin xyz="0 0.25 0.1"/><axis xyz="0 1 0"/><limit effort="0" velocity="20"/>
  </joint>
  <joint name="wheel_right_joint" type="continuous">
    <parent link="base_link"/><child link="wheel_right_link"/>
    <origin xyz="0 -0.25 0.1"/><axis xyz="0 1 0"/><limit effort="0" velocity="20"/>
  </joint>
  <link name="head_link">
    <inertial><mass value="0.5"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial>
    <collision><geometry><sphere radius="0.05"/></geometry></collision>
  </link>
  <joint name="head_joint" type="revolute">
    <parent link="base_link"/><child link="head_link"/>
    <origin xyz="-0.25 0 0.4"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="0" velocity="1"/>
  </joint>
  <link name="link1">
    <inertial><origin xyz="0 0 0.15"/><mass value="2"/>
      <inertia ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.002"/></inertial>
    <collision><origin xyz="0 0 0.15"/>
      <geometry><cylinder radius="0.04" length="0.3"/></geometry></collision>
  </link>
  <joint name="joint1" type="revolute">
    <parent link="base_link"/><child link="link1"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 0 1"/>
    <limit lower="0.1" upper="2.5" effort="0" velocity="2"/>
  </joint>
  <link name="link2">
    <inertial><origin xyz="0.25 0 0"/><mass value="1"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.02"/></inertial>
    <collision><origin xyz="0.25 0 0"/><geometry><box size="0.5 0.06 0.06"/></geometry></collision>
  </link>
  <joint name="joint2" type="revolute">
    <parent link="link1"/><child link="link2"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="0" velocity="2"/>
  </joint>
  <link name="tool"/>
  <joint name="tool_joint" type="fixed">
    <parent link="link2"/><child link="tool"/><origin xyz="0.5 0 0"/>
  </joint>
</robot>
"""

#: The ``robot:`` entry of a scenario for MINI_URDF at ``urdf`` (a path or package:// URI).
def mini_entry(urdf: str) -> dict[str, object]:
    return {"urdf": urdf,
            "platform": {"kind": "differential-drive",
                         "wheels": ["wheel_left_joint", "wheel_right_joint"]},
            "end_effector": "tool", "locked": {"head_joint": 0.5},
            "collision": {"tolerance": 0.02}}


def write_mini(folder: Path, name: str = "mini.urdf") -> Path:
    """MINI_URDF written to ``folder/name``."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(MINI_URDF)
    return path
