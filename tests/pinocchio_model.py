"""Build a Pinocchio model from an mmplan kinematic tree (independent dynamics reference)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from mmplan.robot.robot import Robot
from mmplan.robot.tree import WORLD, JointKind


def _placement(xyz: tuple[float, ...], rpy: tuple[float, ...]) -> pin.SE3:
    return pin.SE3(pin.rpy.rpyToMatrix(np.array(rpy)), np.array(xyz, dtype=float))


def build_pinocchio(robot: Robot) -> tuple[pin.Model, list[int]]:
    """Pinocchio model of ``robot`` and, for each pin q index, the mmplan q index."""
    model = pin.Model()
    # body name -> (pin joint id, placement of the body frame in that joint's frame)
    frames: dict[str, tuple[int, pin.SE3]] = {WORLD: (0, pin.SE3.Identity())}
    order: list[int] = []
    for joint in robot.tree.joints:
        parent_id, parent_in_joint = frames[joint.parent]
        placement = parent_in_joint * _placement(joint.origin_xyz, joint.origin_rpy)
        axis = np.array(joint.axis, dtype=float)
        if joint.kind is JointKind.FIXED:
            frames[joint.child] = (parent_id, placement)
            body_id, body_frame = parent_id, placement
        else:
            if joint.kind is JointKind.REVOLUTE:
                jm = pin.JointModelRevoluteUnaligned(axis)
            else:
                jm = pin.JointModelPrismaticUnaligned(axis)
            body_id = model.addJoint(parent_id, jm, placement, joint.name)
            body_frame = pin.SE3.Identity()
            frames[joint.child] = (body_id, body_frame)
            order.append(robot.coordinates.index(joint.coordinate))
        inertial = robot.tree.bodies[joint.child].inertial
        if inertial.mass > 0:
            inertia = pin.Inertia(inertial.mass, np.array(inertial.com), inertial.inertia_matrix)
            model.appendBodyToJoint(body_id, inertia, body_frame)
    return model, order
