"""Collision spheres fitted to URDF collision geometry, and self-collision pairs.

Coverage is checked against Pinocchio's own placement of the URDF's collision geometry (parsed
again, independently of mmplan's fit): every mesh vertex must lie in the union of its body's
spheres (to VERTEX_SLACK), and dense samples of every collision surface (primitives and mesh
triangles, 5 mm apart, four times denser than the fit's) to SURFACE_SLACK.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from mmplan.errors import InputError
from mmplan.robot import get_robot
from mmplan.robot.robot import CollisionSphere
from mmplan.robot.self_collision import SelfCollision
from mmplan.robot.sphere_fit import fit_spheres
from mmplan.robot.urdf import UrdfRobot
from mmplan.robot.urdf.geometry import box_points, mesh_vertices_and_triangles, surface_points
from tests.robot.test_urdf_robot import random_q
from tests.robot.urdf_oracle import build_oracle, robot_data_dir

#: Mesh vertices are fitted points: covered exactly (rounding only).
VERTEX_SLACK = 1e-9
#: Surface points between the fit's samples (2 cm apart) may stick out by a few mm.
SURFACE_SLACK = 0.008
#: Spacing of the dense surface samples [m].
DENSE = 0.005


def coverage_gaps(robot: UrdfRobot, urdf: str, q: np.ndarray, mount: pin.SE3 | None = None
                  ) -> dict[str, tuple[float, float]]:
    """Per body: worst (vertex gap, surface-sample gap) [m] at q; gap = distance outside the
    union of the body's spheres (negative: inside)."""
    oracle = build_oracle(robot, robot_data_dir() / urdf, mount)
    full = pin.buildModelFromUrdf(str(robot_data_dir() / urdf))
    geom = pin.buildGeomFromUrdf(full, str(robot_data_dir() / urdf), pin.GeometryType.COLLISION,
                                 package_dirs=[str(robot_data_dir().parents[1])])
    model, data = oracle.model, oracle.data
    pin.framesForwardKinematics(model, data, oracle.q(q))
    body_of = {j.coordinate: j.child for j in robot.tree.joints if j.coordinate}
    centers, radii = robot.collision_points(q), robot.collision_radii
    bodies = np.array([s.body for s in robot.collision])
    out: dict[str, tuple[float, float]] = {}
    for obj in geom.geometryObjects:
        link = full.frames[obj.parentFrame].name
        frame = model.frames[model.getFrameId(link)]
        joint = model.names[frame.parentJoint]
        body = "platform" if joint == "planar" else body_of[joint]
        placement = data.oMf[model.getFrameId(link)] * full.frames[obj.parentFrame].placement.inverse() * obj.placement  # noqa: E501
        R, t = placement.rotation, placement.translation
        dense, exact = surface_points(obj.geometry, DENSE, obj.name)
        if hasattr(obj.geometry, "vertices"):
            vertices = mesh_vertices_and_triangles(obj.geometry)[0]
        else:
            vertices = np.zeros((0, 3))
        mine = bodies == body
        gaps = []
        for P in (vertices, np.concatenate([dense, *[c[None] for c, _ in exact]])):
            W = P @ R.T + t
            d = np.linalg.norm(W[:, None, :] - centers[None, mine], axis=2) - radii[None, mine]
            gaps.append(float(d.min(axis=1).max()) if len(W) else -np.inf)
        old = out.get(body, (-np.inf, -np.inf))
        out[body] = (max(old[0], gaps[0]), max(old[1], gaps[1]))
    return out


@pytest.fixture(scope="module")
def tiago() -> UrdfRobot:
    robot_data_dir()
    robot = get_robot("tiago")
    assert isinstance(robot, UrdfRobot)
    return robot


def test_tiago_spheres_cover_every_collision_mesh(tiago: UrdfRobot,
                                                  rng: np.random.Generator) -> None:
    counts = {b: sum(s.body == b for s in tiago.collision) for b in tiago.tree.bodies}
    print("tiago spheres per body:", {b: c for b, c in counts.items() if c})
    moving = {"platform", "wheel_left_link", "torso_lift_link",
              *(f"arm_{i}_link" for i in range(1, 8))}
    assert moving <= {b for b, c in counts.items() if c}
    gaps = coverage_gaps(tiago, "tiago_description/robots/tiago.urdf", random_q(tiago, rng))
    print("worst (vertex, surface) gap per body [m]:",
          {b: (round(v, 9), round(s, 4)) for b, (v, s) in gaps.items()})
    assert set(gaps) >= moving
    for body, (vertex_gap, surface_gap) in gaps.items():
        assert vertex_gap <= VERTEX_SLACK, (body, vertex_gap)
        assert surface_gap <= SURFACE_SLACK, (body, surface_gap)


def test_ur5_omni_spheres_cover_the_arm_meshes_and_the_box(rng: np.random.Generator) -> None:
    from mmplan.robot.library import ur5_omni

    robot_data_dir()
    robot = get_robot("ur5-omni")
    assert isinstance(robot, UrdfRobot)
    mount = pin.SE3(np.eye(3), np.array(ur5_omni.MOUNT_XYZ))
    q = random_q(robot, rng)
    gaps = coverage_gaps(robot, ur5_omni.URDF, q, mount)
    for body, (vertex_gap, surface_gap) in gaps.items():
        assert vertex_gap <= VERTEX_SLACK and surface_gap <= SURFACE_SLACK, (body, gaps[body])
    # the box platform: its surface, 1 cm apart, moved to the pose q
    size = np.array(ur5_omni.BOX_SIZE)
    box = box_points(size / 2, 0.01) + [0, 0, size[2] / 2]
    c, s = np.cos(q[2]), np.sin(q[2])
    world = box @ np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]]) + [q[0], q[1], 0]
    mine = np.array([sp.body == "platform" for sp in robot.collision])
    d = (np.linalg.norm(world[:, None] - robot.collision_points(q)[None, mine], axis=2)
         - robot.collision_radii[None, mine])
    assert d.min(axis=1).max() <= SURFACE_SLACK


def test_fit_covers_every_point_and_sticks_out_by_about_the_tolerance() -> None:
    rng = np.random.default_rng(3)
    half = np.array([0.3, 0.1, 0.05])
    pieces = [box_points(half, 0.01), rng.normal(size=(300, 3)) * 0.02 + [0.5, 0, 0]]
    for tolerance in (0.02, 0.05, 0.1):
        spheres = fit_spheres(pieces, tolerance)
        P = np.concatenate(pieces)
        C = np.array([c for c, _ in spheres])
        R = np.array([r for _, r in spheres])
        gap = (np.linalg.norm(P[:, None] - C[None], axis=2) - R).min(axis=1)
        assert gap.max() <= 1e-12
        # centres inside the box stick out of it by at most tolerance + a voxel diagonal
        in_box = np.all(np.abs(C) <= half, axis=1)
        depth = (half - np.abs(C[in_box])).min(axis=1)
        assert (R[in_box] - depth).max() <= tolerance * (1 + np.sqrt(3) / 2), tolerance
    assert len(fit_spheres(pieces, 0.02)) > len(fit_spheres(pieces, 0.1))
    assert fit_spheres([], 0.05) == []


def test_self_collision_pairs_skip_adjacent_and_overlapping_bodies(
        tiago: UrdfRobot, rng: np.random.Generator) -> None:
    pairs = tiago.self_collision
    checked = set(pairs.body_pairs)
    print("tiago self-collision pairs:", len(checked), "skipped (overlap at rest):", pairs.skipped)
    arm = {f"arm_{i}_link" for i in range(1, 8)}
    adjacent = {frozenset((j.parent, j.child)) for j in tiago.tree.joints}
    assert all(frozenset(p) not in adjacent for p in checked)
    assert {("platform", b) for b in ("arm_4_link", "arm_5_link", "arm_6_link", "arm_7_link")
            } <= checked
    assert ("platform", "wheel_left_link") not in checked
    platform = {"platform", "wheel_left_link", "wheel_right_link"}  # rigid among themselves
    assert all(a not in platform or b not in platform for a, b in checked)
    assert {b for pair in checked for b in pair} >= arm
    # at the reference pose every checked pair is apart; the skipped ones overlap there
    ref = tiago.source.reference
    assert tiago.self_collision_distances(ref).min() >= 0
    P, r = tiago.collision_points(ref), tiago.collision_radii
    bodies = np.array([s.body for s in tiago.collision])
    for a, b in pairs.skipped:
        ia, ib = np.flatnonzero(bodies == a), np.flatnonzero(bodies == b)
        gap = np.linalg.norm(P[ia, None] - P[None, ib], axis=2) - r[ia, None] - r[None, ib]
        assert gap.min() < 0, (a, b)
    # some random poses of the arm hit the base or the torso
    hits = sum(tiago.self_collision_distances(random_q(tiago, rng)).min() < 0 for _ in range(50))
    assert 0 < hits < 50


def test_distances_are_sphere_gaps() -> None:
    pairs = SelfCollision((("a", "b"),), np.array([[0, 1], [0, 2]]))
    points = np.array([[0.0, 0, 0], [1.0, 0, 0], [0.0, 0.5, 0]])
    radii = np.array([0.1, 0.2, 0.5])
    np.testing.assert_allclose(pairs.distances(points, radii), [0.7, -0.1])


def test_collision_spheres_can_be_replaced(tiago: UrdfRobot) -> None:
    q = tiago.source.reference
    spheres = [CollisionSphere("arm_7_link", (0.0, 0.0, 0.05), 0.08)]
    other = tiago.with_collision(spheres)
    assert other.collision == tuple(spheres) and len(tiago.collision) > 1
    assert other.collision_points(q).shape == (1, 3)
    assert other.self_collision.sphere_pairs.shape == (0, 2)
    np.testing.assert_allclose(other.collision_radii, [0.08])
    np.testing.assert_allclose(other.ee_position(q), tiago.ee_position(q))
    with pytest.raises(Exception, match="unknown body"):
        tiago.with_collision([CollisionSphere("hand", (0, 0, 0), 0.1)])


def test_robots_without_example_robot_data_say_how_to_install(monkeypatch: pytest.MonkeyPatch
                                                              ) -> None:
    import re

    from mmplan.extras import install_command
    from mmplan.robot import robot_data
    from mmplan.robot.library import tiago, ur5_omni

    monkeypatch.setattr(robot_data, "_candidates", lambda: [])
    for module in (tiago, ur5_omni):
        with pytest.raises(InputError, match=re.escape(install_command("robots"))) as info:
            module.build()
        assert "\n" not in str(info.value)
