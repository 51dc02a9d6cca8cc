"""Pinocchio oracle for URDF robots: the same file, a planar root joint, the same held joints.

The oracle is built independently of mmplan's tree: the URDF is parsed again, a composite
joint (x slide, y slide, yaw) carries the URDF root at the mount, the platform box (if any) is
appended to it, and Pinocchio's buildReducedModel holds every joint that mmplan holds at the
values mmplan reports. Pinocchio then gives frame placements (FK), CRBA and RNEA.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from mmplan.robot.urdf import UrdfRobot


def robot_data_dir() -> Path:
    """example-robot-data's robots folder, or skip the test saying how to get it."""
    from mmplan.errors import InputError
    from mmplan.robot.robot_data import robot_data_dir as locate

    try:
        return locate()
    except InputError as exc:
        pytest.skip(f"example-robot-data missing ({exc.problem})")


@dataclass
class Oracle:
    """A reduced Pinocchio model and the maps from mmplan's q to Pinocchio's q and v."""

    model: pin.Model
    data: pin.Data
    robot: UrdfRobot

    def q(self, q: np.ndarray) -> np.ndarray:
        """Pinocchio configuration of mmplan's q."""
        out = pin.neutral(self.model)
        out[:3] = q[:3]
        for k, name in enumerate(self.robot.coordinates[3:], start=3):
            jid = self.model.getJointId(name)
            i = self.model.idx_qs[jid]
            if self.model.joints[jid].nq == 2:
                out[i : i + 2] = np.cos(q[k]), np.sin(q[k])
            else:
                out[i] = q[k]
        return out

    @property
    def v_index(self) -> list[int]:
        """For each mmplan coordinate, its Pinocchio velocity index."""
        idx = [0, 1, 2]
        for name in self.robot.coordinates[3:]:
            idx.append(int(self.model.idx_vs[self.model.getJointId(name)]))
        return idx


def build_oracle(
    robot: UrdfRobot,
    urdf: Path,
    mount: pin.SE3 | None = None,
    box: tuple[float, tuple[float, float, float], tuple[float, float, float]] | None = None,
) -> Oracle:
    """Oracle of ``robot`` loaded from ``urdf`` (``box``: mass, size, centre on the platform)."""
    planar = pin.JointModelComposite(pin.JointModelPX())
    planar.addJoint(pin.JointModelPY())
    planar.addJoint(pin.JointModelRZ())
    base = pin.Model()
    jid = base.addJoint(0, planar, pin.SE3.Identity(), "planar")
    if box is not None:
        mass, size, center = box
        inertia = pin.SE3(np.eye(3), np.array(center)).act(pin.Inertia.FromBox(mass, *size))
        base.appendBodyToJoint(jid, inertia, pin.SE3.Identity())
    frame = base.addFrame(pin.Frame("platform", jid, 0, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
    urdf_model = pin.buildModelFromUrdf(str(urdf))
    full = pin.appendModel(base, urdf_model, frame, mount or pin.SE3.Identity())
    moving = set(robot.coordinates[3:]) | {"planar"}
    q_ref = pin.neutral(full)
    lock = []
    for j in range(1, full.njoints):
        name = full.names[j]
        if name in moving:
            continue
        lock.append(j)
        value = robot.source.held.get(name)
        if value is None:
            continue
        i = full.idx_qs[j]
        if full.joints[j].nq == 2:
            q_ref[i : i + 2] = np.cos(value), np.sin(value)
        else:
            q_ref[i] = value
    model = pin.buildReducedModel(full, lock, q_ref)
    return Oracle(model, model.createData(), robot)
