"""ur5-omni: a Universal Robots UR5 (its URDF) on an omnidirectional box platform.

The UR5 is ``ur_description/urdf/ur5_robot.urdf`` of example-robot-data (optional extra
``robots``), loaded by :func:`~mmplan.robot.urdf.load_urdf_robot` as an arm-only URDF with a
``mount``. q = (x, y, theta, shoulder_pan_joint, shoulder_lift_joint, elbow_joint,
wrist_1_joint, wrist_2_joint, wrist_3_joint); n = 9, h = 0. End effector: ``tool0``.

The platform is ASSUMED (no such product in the package): a uniform box 0.8 x 0.6 x 0.4 m of
80 kg on the ground (about a Clearpath Ridgeback's footprint), the UR5 base on its top,
0.2 m ahead of the centre. Joint, velocity and effort limits and the arm's inertias: the URDF.
Self-collision pairs also skip the SRDF's ``disable_collisions`` (``ur_description/srdf/ur5.srdf``).
"""

from __future__ import annotations

from mmplan.robot.robot import Robot
from mmplan.robot.robot_data import robot_data_file

URDF = "ur_description/urdf/ur5_robot.urdf"
SRDF = "ur_description/srdf/ur5.srdf"
BOX_SIZE = (0.8, 0.6, 0.4)
BOX_MASS = 80.0
MOUNT_XYZ = (0.2, 0.0, BOX_SIZE[2])
END_EFFECTOR = "tool0"


def build() -> Robot:
    """Build ur5-omni (a :class:`~mmplan.robot.urdf.UrdfRobot`; an InputError naming
    ``pip install 'mmplan[robots]'`` without the URDF)."""
    from mmplan.robot.urdf import load_urdf_robot  # Pinocchio and SciPy: only when built

    return load_urdf_robot(
        robot_data_file(URDF),
        platform={"kind": "omnidirectional", "box": {"size": list(BOX_SIZE), "mass": BOX_MASS}},
        end_effector=END_EFFECTOR,
        mount={"xyz": list(MOUNT_XYZ)},
        srdf=robot_data_file(SRDF),
        name="ur5-omni",
        description="UR5 from its URDF (example-robot-data) on an omnidirectional box platform "
        "(0.8 x 0.6 x 0.4 m, 80 kg, assumed), end effector tool0.",
    )
