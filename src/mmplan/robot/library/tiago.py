"""tiago: PAL Robotics TIAGo (differential drive, torso lift, 7-dof arm) from its URDF.

The unmodified ``tiago_description/robots/tiago.urdf`` of example-robot-data (optional extra
``robots``: ``pip install 'mmplan[robots]'``) loaded by
:func:`~mmplan.robot.urdf.load_urdf_robot`. q = (x, y, theta, wheel_left_joint,
wheel_right_joint, torso_lift_joint, arm_1_joint, ..., arm_7_joint); n = 13, h = 3; the planar
pose places ``base_footprint`` on the ground. End effector: ``arm_tool_link`` (the flange).
The head and the hand's fingers are held at zero and merged into the torso and the last arm
link. Derived from the file: wheel radius 0.0985 m (wheel collision cylinder), half track
0.2022 m (wheel joint origins). Joint, velocity and effort limits (torso [0, 0.35] m,
0.07 m/s, 2000 N; arm_1 [0, 2.75] rad, 2.7 rad/s, 39 N m; wheels 10.15 rad/s, 6 N m) and
inertias: the URDF. Collision spheres fitted to the URDF's collision meshes
(:mod:`mmplan.robot.urdf.collision`).
"""

from __future__ import annotations

from mmplan.robot.robot import Robot
from mmplan.robot.robot_data import robot_data_file

URDF = "tiago_description/robots/tiago.urdf"
WHEELS = ("wheel_left_joint", "wheel_right_joint")
END_EFFECTOR = "arm_tool_link"


def build() -> Robot:
    """Build tiago (a :class:`~mmplan.robot.urdf.UrdfRobot`; an InputError naming
    ``pip install 'mmplan[robots]'`` without the URDF)."""
    from mmplan.robot.urdf import load_urdf_robot  # Pinocchio and SciPy: only when built

    return load_urdf_robot(
        robot_data_file(URDF),
        platform={"kind": "differential-drive", "wheels": list(WHEELS)},
        end_effector=END_EFFECTOR,
        name="tiago",
        description="PAL TIAGo from its URDF (example-robot-data): differential drive, torso "
        "lift, 7-dof arm to arm_tool_link; head and hand held.",
    )
