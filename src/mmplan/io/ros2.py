r"""A trajectory as a ROS 2 bag (rosbag2), written without ROS by ``rosbags`` (extra ``ros``).

Topics, for a trajectory sampled at the control rate (:func:`mmplan.io.resample`):

* ``/joint_trajectory``: one ``trajectory_msgs/msg/JointTrajectory``. ``joint_names`` are the
  robot's coordinates after the planar base pose (x, y, heading): wheels or steering, then
  the arm (URDF joint names for URDF arms). One point per sample with ``positions``,
  ``velocities``, ``accelerations``, ``effort`` (the ``tau`` column of the actuator that
  drives that joint alone, when the trajectory has efforts and every joint has such an
  actuator; else empty) and ``time_from_start`` = t - t0. ``header.stamp`` is zero ("start
  on receipt" for ros2_control's joint_trajectory_controller).
* ``/cmd_vel``: one ``geometry_msgs/msg/Twist`` per sample, at bag time t - t0 after the
  start: the base velocity in the platform frame,
  :math:`v_x = \cos\theta\,\dot x + \sin\theta\,\dot y`,
  :math:`v_y = -\sin\theta\,\dot x + \cos\theta\,\dot y`, :math:`\omega_z = \dot\theta`.
  ``linear.x`` and ``angular.z`` for differential drives, unicycles and cars (their
  reference point cannot move sideways: ``linear.y`` is 0 and the dropped
  :math:`|v_y|` is at most the Pfaffian residual, ``BagSummary.lateral_dropped``);
  ``linear.y`` too for omnidirectional platforms.
* ``/base_path``: one ``nav_msgs/msg/Path`` in frame ``odom``: a ``PoseStamped`` per sample
  (position (x, y, 0), heading as the quaternion (0, 0, sin(theta/2), cos(theta/2)), stamp
  t - t0 after the start).

Message definitions are those of ROS 2 Humble in rosbags' typestore (identical in Jazzy,
same RIHS01 hashes). The bag is rosbag2 format version 8 (the oldest rosbags writes) with
sqlite3 storage, written to a temporary folder renamed into place when complete. It was
read back with rosbags' reader here; it has not been played with a ROS installation.
"""

from __future__ import annotations

import math
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

from mmplan.arrays import Array
from mmplan.errors import InputError, path_argument, require
from mmplan.extras import install_command
from mmplan.robot import Robot
from mmplan.robot.bases import Omnidirectional
from mmplan.trajectory import Trajectory

TOPIC_TRAJECTORY = "/joint_trajectory"
TOPIC_CMD_VEL = "/cmd_vel"
TOPIC_PATH = "/base_path"
FRAME = "odom"
#: Coordinates of the planar base pose (x, y, heading): the first three of every platform kind.
BASE_POSE = 3
BAG_VERSION: Literal[8] = 8


def require_rosbags() -> None:
    """InputError (``--ros2``) naming the install command when rosbags is missing."""
    try:
        from rosbags import rosbag2, typesys  # noqa: F401
    except ImportError:
        raise InputError("--ros2", f"writing a ROS 2 bag needs the rosbags package: "
                         f"{install_command('ros')}") from None


@dataclass(frozen=True)
class BagSummary:
    """What :func:`write_bag` wrote.

    Attributes:
        path: The bag folder.
        counts: Messages per topic.
        points: Points of the JointTrajectory (= Twist messages = Path poses).
        joint_names: JointTrajectory joint names.
        effort: Whether the points carry efforts.
        lateral_dropped: max |v_y| left out of the Twists of a non-omnidirectional base [m/s].
    """

    path: Path
    counts: dict[str, int]
    points: int
    joint_names: tuple[str, ...]
    effort: bool
    lateral_dropped: float


def check_bag_dir(path: str | Path) -> Path:
    """``path`` (absolute) when a bag may be written there, else InputError (``--ros2``).

    Accepted: a path that does not exist yet, an empty folder, or an earlier rosbag2 folder
    (metadata.yaml and .db3/.mcap files only), replaced once the new bag is complete.
    """
    out = path_argument(path, "--ros2")
    if not str(path).strip():
        raise InputError("--ros2", "empty path")
    try:
        full, cwd = out.resolve(), Path.cwd().resolve()
    except (OSError, RuntimeError) as exc:
        raise InputError("--ros2", f"{out}: {exc}") from None
    if full == cwd or full in cwd.parents or full.parent == full:
        raise InputError("--ros2", f"{out} is the working directory, one of its parents or the "
                         "root; name a new folder")
    if out.is_symlink() or (out.exists() and not out.is_dir()):
        raise InputError("--ros2", f"{out} exists and is not a directory")
    if out.is_dir():
        try:
            names = [p.name for p in out.iterdir()]
        except OSError as exc:
            raise InputError("--ros2", f"{out}: {exc.strerror or exc}") from None
        if names and not _is_bag(out, names):
            raise InputError("--ros2", f"{out} exists and is not a rosbag2 folder")
    return full


def _is_bag(folder: Path, names: list[str]) -> bool:
    return "metadata.yaml" in names and all(
        n == "metadata.yaml" or (n.endswith((".db3", ".mcap")) and (folder / n).is_file())
        for n in names)


def _stamp(seconds: float) -> tuple[int, int]:
    """(sec, nanosec) of a time >= 0, nanoseconds rounded."""
    ns = round(seconds * 1e9)
    return ns // 1_000_000_000, ns % 1_000_000_000


def joint_efforts(robot: Robot, trajectory: Trajectory) -> Array | None:
    """Efforts of the joints after the base pose, (N, n - 3), or None.

    A joint's effort is the tau column of the actuator whose actuation column is the unit
    vector of that joint at every sample (wheels of a differential drive, a car's steering,
    every arm joint). None when the trajectory has no efforts or some joint has no such
    actuator.
    """
    tr = trajectory
    if tr.tau is None or tr.actuators != robot.actuators:
        return None
    N, n, a = tr.samples, robot.n, len(robot.actuators)
    B = np.asarray(robot.functions["actuation"].map(N)(np.ascontiguousarray(tr.q.T)), dtype=float)
    B = B.reshape(n, N, a)
    columns = []
    for j in range(BASE_POSE, n):
        unit = np.zeros(n)
        unit[j] = 1.0
        match = [k for k in range(a) if np.allclose(B[:, :, k], unit[:, None], atol=1e-12)]
        if not match:
            return None
        columns.append(match[0])
    return np.asarray(tr.tau[:, columns], dtype=float)


def base_twists(robot: Robot, trajectory: Trajectory) -> tuple[Array, float]:
    """(v_x, v_y, omega_z) per sample in the platform frame, (N, 3), and the dropped |v_y|.

    v_y is set to 0 unless the platform is omnidirectional; the second value is the largest
    |v_y| so dropped.
    """
    q, dq = trajectory.q, trajectory.dq
    c, s = np.cos(q[:, 2]), np.sin(q[:, 2])
    vx = c * dq[:, 0] + s * dq[:, 1]
    vy = -s * dq[:, 0] + c * dq[:, 1]
    if isinstance(robot.platform, Omnidirectional):
        return np.column_stack([vx, vy, dq[:, 2]]), 0.0
    return np.column_stack([vx, np.zeros_like(vx), dq[:, 2]]), float(np.max(np.abs(vy)))


def write_bag(trajectory: Trajectory, robot: Robot, out: str | Path,
              start_ns: int = 0) -> BagSummary:
    """Write ``trajectory`` (already at the control rate) as a rosbag2 folder ``out``.

    Args:
        trajectory: The trajectory, one message or point per sample (:func:`resample` it
            first: Twists are sent at every sample).
        robot: The robot (joint names, platform kind, actuation).
        out: The bag folder (see :func:`check_bag_dir`).
        start_ns: Bag time of the first sample [ns].

    Raises:
        InputError: rosbags missing, ``out`` may not be written.
    """
    require(trajectory, Trajectory, "trajectory", "a Trajectory")
    require(robot, Robot, "robot", "a Robot")
    require_rosbags()
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    folder = check_bag_dir(out)
    store = get_typestore(Stores.ROS2_HUMBLE)
    efforts = joint_efforts(robot, trajectory)
    twists, lateral = base_twists(robot, trajectory)
    messages = _messages(store.types, robot, trajectory, efforts, twists, start_ns)
    try:
        folder.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{folder.name}.tmp-", dir=folder.parent))
    except OSError as exc:
        raise InputError("--ros2", f"cannot create {folder}: {exc.strerror or exc}") from None
    counts: dict[str, int] = {}
    try:
        with Writer(tmp / folder.name, version=BAG_VERSION) as writer:
            connections: dict[str, Any] = {}
            for topic, msgtype, stamp, msg in messages:
                if topic not in connections:
                    connections[topic] = writer.add_connection(topic, msgtype, typestore=store)
                writer.write(connections[topic], stamp, store.serialize_cdr(msg, msgtype))
                counts[topic] = counts.get(topic, 0) + 1
        _replace_bag(tmp / folder.name, folder)
    except OSError as exc:
        raise InputError("--ros2", f"cannot write {folder}: {exc.strerror or exc}") from None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return BagSummary(folder, counts, trajectory.samples, robot.coordinates[BASE_POSE:],
                      efforts is not None, lateral)


def _replace_bag(new: Path, out: Path) -> None:
    from mmplan.io.plan_folder import _replace

    _replace(new, out)


def _messages(types: Any, robot: Robot, tr: Trajectory, efforts: Array | None, twists: Array,
              start_ns: int) -> list[tuple[str, str, int, Any]]:
    """(topic, type, bag time [ns], message) in bag order."""
    Time, Duration = types["builtin_interfaces/msg/Time"], types["builtin_interfaces/msg/Duration"]
    Header = types["std_msgs/msg/Header"]
    Vector3, Twist = types["geometry_msgs/msg/Vector3"], types["geometry_msgs/msg/Twist"]
    Point, Quaternion = types["geometry_msgs/msg/Point"], types["geometry_msgs/msg/Quaternion"]
    Pose, PoseStamped = types["geometry_msgs/msg/Pose"], types["geometry_msgs/msg/PoseStamped"]
    JT = "trajectory_msgs/msg/JointTrajectory"
    JTP = types["trajectory_msgs/msg/JointTrajectoryPoint"]
    elapsed = tr.t - tr.t[0]
    stamps = [start_ns + round(float(e) * 1e9) for e in elapsed]

    def time(ns: int) -> Any:
        return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)

    joints = slice(BASE_POSE, robot.n)
    empty = np.zeros(0)
    points = [JTP(positions=tr.q[k, joints].copy(), velocities=tr.dq[k, joints].copy(),
                  accelerations=tr.ddq[k, joints].copy(),
                  effort=empty if efforts is None else efforts[k].copy(),
                  time_from_start=Duration(*_stamp(float(elapsed[k]))))
              for k in range(tr.samples)]
    trajectory = types[JT](header=Header(stamp=time(0), frame_id=""),
                           joint_names=list(robot.coordinates[joints]), points=points)
    poses = [PoseStamped(header=Header(stamp=time(stamps[k]), frame_id=FRAME),
                         pose=Pose(position=Point(x=float(tr.q[k, 0]), y=float(tr.q[k, 1]), z=0.0),
                                   orientation=Quaternion(x=0.0, y=0.0,
                                                          z=math.sin(0.5 * tr.q[k, 2]),
                                                          w=math.cos(0.5 * tr.q[k, 2]))))
             for k in range(tr.samples)]
    path = types["nav_msgs/msg/Path"](header=Header(stamp=time(stamps[0]), frame_id=FRAME),
                                      poses=poses)
    out: list[tuple[str, str, int, Any]] = [(TOPIC_TRAJECTORY, JT, stamps[0], trajectory),
                                            (TOPIC_PATH, "nav_msgs/msg/Path", stamps[0], path)]
    zero = 0.0
    out += [(TOPIC_CMD_VEL, "geometry_msgs/msg/Twist", stamps[k],
             Twist(linear=Vector3(x=float(v[0]), y=float(v[1]), z=zero),
                   angular=Vector3(x=zero, y=zero, z=float(v[2]))))
            for k, v in enumerate(twists)]
    return out
