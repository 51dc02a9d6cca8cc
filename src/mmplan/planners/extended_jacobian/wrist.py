r"""The point whose manipulability the extended-Jacobian criterion maximises (real robots).

[PajakPajak] eq. (5) and [Pajak] eq. (7) measure mu = sqrt(det(J_a J_a^T)) at the end
effector of a planar 3- or 4-joint arm. A real arm often ends in a wrist whose joint axes all
pass through one point W (TIAGo: arm_5, arm_6 and arm_7 meet at arm_6's origin, 0.046 m
before the tool point arm_tool_link, which lies on arm_7's axis). For a position task those
joints move the tool point only through that short lever, and mu at the tool point depends
on them in a degenerate way: arm_7's column is identically zero, arm_5's vanishes whenever
arm_6 = 0, and the curvature of mu along arm_5 changes sign with arm_6. Measured on TIAGo
(start with arm_6 = 0, goal (1.5, 0.5, 0.8) m): the reduced Hessian of the criterion had an
eigenvalue 0.0004 at the start; when arm_6 crossed 0 at t = 2.3 s the drift -E^-1 v1 grew
from 5 to 1.9e3 rad/s^2 within 0.1 s and the state became NaN (an algorithmic singularity:
E singular although J is not).

Here mu is measured at W over the joints before the wrist (the positioning joints), so the
wrist joints drop out of mu (their columns of dW/dq are zero by construction) and are set
by the joint-limit penalty and the posture term of
:mod:`~mmplan.planners.extended_jacobian.criterion` alone (convex along them). The task is
still the tool point. A robot without such a wrist (every robot of the papers: no trailing
joint axis passes through a common point) keeps mu at the end effector, unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from mmplan.arrays import Array
from mmplan.compile.disk_memo import remember
from mmplan.robot.robot import Robot
from mmplan.robot.tree import WORLD, JointKind

#: A joint axis passes through a point when it is closer than this [m].
ON_AXIS = 1e-9


@dataclass(frozen=True)
class Wrist:
    """A wrist centre: the point W (``offset`` in the frame of ``body``, the parent body of
    the first wrist joint) and the arm coordinates (indices, robot order) of the wrist joints,
    whose axes all pass through W."""

    body: str
    offset: tuple[float, float, float]
    joints: tuple[int, ...]


def _ee_chain(robot: Robot) -> list[int]:
    """Joints (indices into ``robot.tree.joints``) from the world to the end-effector body."""
    chain, body = [], robot.end_effector.body
    index = {j.child: k for k, j in enumerate(robot.tree.joints)}
    while body != WORLD:
        k = index[body]
        chain.append(k)
        body = robot.tree.joints[k].parent
    return chain[::-1]


def _generic_configuration(robot: Robot) -> Array:
    """Arm joints at 0.37 of their ranges (an arbitrary, generic posture), platform at 0."""
    q = np.zeros(robot.n)
    lo = np.where(np.isfinite(robot.limits.joint_min), robot.limits.joint_min, -1.0)
    hi = np.where(np.isfinite(robot.limits.joint_max), robot.limits.joint_max, 1.0)
    q[list(robot.arm_indices)] = lo + 0.37 * (hi - lo)
    return q


def _distance_to_axis(point: Array, origin: Array, axis: Array) -> float:
    d = point - origin
    return float(np.linalg.norm(d - (d @ axis) * axis))


def find_wrist(robot: Robot) -> Wrist | None:
    """The longest trailing run of revolute arm joints whose axes meet in one point (module
    docstring), with that point; None when there is none.

    Candidate points: the end-effector point and the intersection of the last two axes. The
    geometry is read at one generic configuration: whether later axes pass through a point
    on an earlier axis does not depend on the joint values. Kept per robot object and on disk
    by the model's fingerprint (:mod:`mmplan.compile.disk_memo`; finding it builds CasADi
    functions of the symbolic model, 5-9 ms, twice a plan before).
    """
    return remember(robot, __file__, "wrist", 0, lambda: _find_wrist(robot), _encode, _decode)


def _encode(wrist: Wrist | None) -> Any:
    return None if wrist is None else [wrist.body, list(wrist.offset), list(wrist.joints)]


def _decode(data: Any) -> Wrist | None:
    if data is None:
        return None
    body, offset, joints = data
    x, y, z = (float(v) for v in offset)
    return Wrist(str(body), (x, y, z), tuple(int(j) for j in joints))


def _find_wrist(robot: Robot) -> Wrist | None:
    """:func:`find_wrist`, computed."""
    s = robot.symbols
    joints = robot.tree.joints
    arm = set(robot.arm_coordinates)
    chain = [k for k in _ee_chain(robot) if joints[k].coordinate in arm]
    if not chain:
        return None
    q = _generic_configuration(robot)
    frames = ca.Function("frames", [s.q], [s.transforms[joints[k].child] for k in chain])
    T = [np.asarray(m, dtype=float) for m in frames(q)]
    origins = [m[:3, 3] for m in T]
    axes = [
        m[:3, :3] @ np.asarray(joints[k].axis, dtype=float)
        for m, k in zip(T, chain, strict=True)
    ]
    ee = np.asarray(robot.ee_position(q), dtype=float)
    candidates = [ee]
    if len(chain) >= 2:
        point = _intersection(origins[-2], axes[-2], origins[-1], axes[-1])
        if point is not None:
            candidates.append(point)
    best: tuple[int, Array] | None = None
    for point in candidates:
        run = 0
        for k in range(len(chain) - 1, -1, -1):
            if joints[chain[k]].kind is not JointKind.REVOLUTE:
                break
            if _distance_to_axis(point, origins[k], axes[k]) > ON_AXIS:
                break
            run += 1
        if run and (best is None or run > best[0]):
            best = (run, point)
    if best is None or best[0] == len(chain):
        return None  # no wrist, or nothing left to position it
    run, point = best
    first = joints[chain[-run]]
    T_parent = np.asarray(
        ca.Function("parent", [s.q], [s.transforms[first.parent]])(q), dtype=float
    )
    local = np.linalg.solve(T_parent, np.r_[point, 1.0])[:3]
    coords = [joints[k].coordinate for k in chain[-run:]]
    indices = tuple(robot.coordinates.index(c) for c in coords if c is not None)
    return Wrist(first.parent, (float(local[0]), float(local[1]), float(local[2])), indices)


def _intersection(o1: Array, a1: Array, o2: Array, a2: Array) -> Array | None:
    """The common point of two lines (origin, unit axis), None when they do not meet."""
    cross = np.cross(a1, a2)
    if float(np.linalg.norm(cross)) < 1e-9:
        return None  # parallel
    # closest points o1 + t1 a1 and o2 + t2 a2
    A = np.array([[a1 @ a1, -(a1 @ a2)], [a1 @ a2, -(a2 @ a2)]])
    b = np.array([(o2 - o1) @ a1, (o2 - o1) @ a2])
    t1, t2 = np.linalg.solve(A, b)
    p1, p2 = o1 + t1 * a1, o2 + t2 * a2
    if float(np.linalg.norm(p1 - p2)) > ON_AXIS:
        return None  # skew
    return 0.5 * (p1 + p2)


def wrist_jacobian(robot: Robot, wrist: Wrist) -> ca.SX:
    """dW/dq over the positioning arm joints (3, n_arm - len(wrist.joints)), symbolic."""
    s = robot.symbols
    T = s.transforms[wrist.body]
    W = T[:3, :3] @ ca.DM(wrist.offset) + T[:3, 3]
    keep = [i for i in robot.arm_indices if i not in wrist.joints]
    return ca.jacobian(W, s.q)[:, keep]


def positioning_joints(robot: Robot) -> int:
    """Number of arm joints that position the manipulability point (all arm joints without
    a wrist, else those before it)."""
    wrist = find_wrist(robot)
    return len(robot.arm_indices) - (len(wrist.joints) if wrist is not None else 0)
