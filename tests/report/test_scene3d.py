"""The 3D view's meshcat commands, decoded from the page as the browser would: the animation
moves each body as the robot's forward kinematics does, obstacles keep their true shapes, the
robot is drawn from its model; the mesh and quaternion helpers against closed forms."""

from __future__ import annotations

import base64
import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import umsgpack

from mmplan.robot import get_robot
from tests.report.plans import make_plan_dir


@pytest.fixture(scope="module")
def commands(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[dict[str, Any]],
                                                                 dict[str, Any]]:
    from mmplan.report import write_report

    folder = make_plan_dir(tmp_path_factory.mktemp("scene") / "plan")
    html = write_report(folder, max_frames=300, parallel=False).read_text()
    match = re.search(r'<script id="mmplan-scene" type="application/json">(.*?)</script>', html)
    assert match is not None
    scene = json.loads(match.group(1))
    decoded = [umsgpack.unpackb(base64.b64decode(c)) for c in scene["commands"]]
    return folder, decoded, scene["meta"]


def _floats(ext: Any) -> np.ndarray:
    assert isinstance(ext, umsgpack.Ext) and ext.type == 0x17  # Float32Array
    return np.frombuffer(ext.data, dtype="<f4").astype(float)


def _rotation(quat_xyzw: np.ndarray) -> np.ndarray:
    x, y, z, w = quat_xyzw
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def _objects(decoded: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    return {c["path"]: c["object"] for c in decoded if c["type"] == "set_object"}


def _transforms(decoded: list[dict[str, Any]]) -> dict[str, np.ndarray]:
    return {c["path"]: np.array(c["matrix"]).reshape(4, 4).T
            for c in decoded if c["type"] == "set_transform"}


def test_animation_moves_bodies_as_forward_kinematics(commands: Any) -> None:
    folder, decoded, meta = commands
    (animation,) = [c for c in decoded if c["type"] == "set_animation"]
    assert animation["options"] == {"play": False, "repetitions": 1}
    clips = {a["path"]: a["clip"] for a in animation["animations"]}
    assert set(clips) == {f"/{b}" for b in meta["bodies"]}
    robot = get_robot("youbot-3r")
    data = np.loadtxt(folder / "trajectory.csv", delimiter=",", skiprows=1)
    tracks = {t["name"]: t for t in clips["/robot/link3"]["tracks"]}
    times = _floats(tracks[".position"]["times"])
    assert len(times) == meta["frames"] == 300 and times[0] == 0.0
    positions = _floats(tracks[".position"]["values"]).reshape(-1, 3)
    quats = _floats(tracks[".quaternion"]["values"]).reshape(-1, 4)
    for k in (0, 137, 299):
        i = int(np.argmin(np.abs(data[:, 0] - times[k])))
        q = data[i, 1 : 1 + robot.n]
        np.testing.assert_allclose(positions[k], robot.body_positions(q)["link3"], atol=1e-5)
        tip = positions[k] + _rotation(quats[k]) @ [0.34, 0.0, 0.0]  # the tool on link3's x
        np.testing.assert_allclose(tip, robot.ee_position(q), atol=1e-5)
        wheel = clips["/robot/wheel1"]["tracks"][0]
        wheel_at = _floats(wheel["values"]).reshape(-1, 3)[k]
        np.testing.assert_allclose(wheel_at, robot.body_positions(q)["wheel1"], atol=1e-5)


def test_obstacles_are_drawn_in_their_true_shapes(commands: Any) -> None:
    _, decoded, meta = commands
    objects, poses = _objects(decoded), _transforms(decoded)
    sphere = objects["/obstacles/2_sphere"]["geometries"][0]
    assert sphere["type"] == "SphereGeometry" and sphere["radius"] == 0.15
    np.testing.assert_allclose(poses["/obstacles/2_sphere"][:3, 3], [1.25, 0.70, 0.45])
    cylinder = objects["/obstacles/3_cylinder"]["geometries"][0]
    assert cylinder["type"] == "CylinderGeometry"
    assert (cylinder["radiusTop"], cylinder["height"]) == (0.40, 0.10)
    pose = poses["/obstacles/3_cylinder"]
    np.testing.assert_allclose(pose[:3, 3], [1.25, 2.5, 0.05])  # half way up
    np.testing.assert_allclose(pose[:3, :3] @ [0, 1, 0], [0, 0, 1], atol=1e-12)  # y -> up
    mesh = objects["/obstacles/1_superellipsoid"]["geometries"][0]
    vertices = _floats(mesh["data"]["attributes"]["position"]["array"]).reshape(-1, 3)
    from mmplan.scene import obstacle_from_dict
    from tests.report.plans import PAPER_OBSTACLES

    model = obstacle_from_dict(PAPER_OBSTACLES[0]).superellipsoid()
    np.testing.assert_allclose(model.gauge(vertices), 1.0, atol=1e-4)  # on the surface
    labels = [label[3] for label in meta["labels"]]
    assert {"obstacle 1 superellipsoid", "obstacle 2 sphere", "obstacle 3 cylinder",
            "start", "goal"} <= set(labels)


def test_robot_bodies_are_drawn_from_the_model(commands: Any) -> None:
    _, decoded, _ = commands
    objects, poses = _objects(decoded), _transforms(decoded)
    body = objects["/robot/platform/body"]["geometries"][0]
    assert body["type"] == "BoxGeometry"
    np.testing.assert_allclose([body["width"], body["height"], body["depth"]],
                               [0.456, 0.316, 0.046])  # the inertia's box
    np.testing.assert_allclose(poses["/robot/platform/body"][:3, 3], [0, 0, 0.084])
    wheel = objects["/robot/wheel1/wheel"]["geometries"][0]
    assert wheel["type"] == "CylinderGeometry" and np.isclose(wheel["radiusTop"], 0.05)
    np.testing.assert_allclose(poses["/robot/wheel1/wheel"][:3, :3] @ [0, 1, 0], [0, 1, 0],
                               atol=1e-12)  # about the axle (y)
    link = objects["/robot/link3/link_0"]["geometries"][0]
    assert link["type"] == "CylinderGeometry" and np.isclose(link["height"], 0.34)
    np.testing.assert_allclose(poses["/robot/link3/link_0"][:3, 3], [0.17, 0, 0], atol=1e-12)
    hidden = [c for c in decoded if c["type"] == "set_property" and c["property"] == "visible"]
    assert {"path": "/robot/platform/collision", "property": "visible", "value": False,
            "type": "set_property"} in hidden
    assert all(c["object"]["object"]["uuid"].startswith("mmplan-")
               for c in decoded if c["type"] == "set_object")  # no host address, reproducible


def test_builtin_robots_get_bodies_wheels_and_links() -> None:
    from mmplan.report.visuals import VisualKind, body_visuals

    car = body_visuals(get_robot("car-rtr"), {"x2": (0.2, 0.9)})
    wheels = [v for vs in car.values() for v in vs if v.name.startswith("wheel_")
              and v.kind is VisualKind.CYLINDER]
    assert len(wheels) == 4 and set(car) >= {"platform", "steering", "turret", "slider"}
    (rail,) = [v for v in car["turret"] if v.name.startswith("rail_")]
    assert np.isclose(rail.size[1], 0.9 + 2 * rail.size[0] / 0.8)  # [0, 0.9] and its ends
    for name in ("youbot-4r", "diffdrive-3dof", "omni-3dof", "base-6dof"):
        robot = get_robot(name)
        visuals = body_visuals(robot)
        assert "platform" in visuals, name
        links = [v for vs in visuals.values() for v in vs if v.name.startswith("link_")]
        assert len(links) >= 3, name
        (tool,) = [v for v in visuals[robot.end_effector.body] if v.name == "tool"]
        np.testing.assert_allclose(tool.pose[:3, 3], robot.end_effector.offset)


def test_quaternions_match_rotation_matrices() -> None:
    from mmplan.report.meshcat_commands import quaternions_xyzw

    rng = np.random.default_rng(11)
    raw = rng.normal(size=(200, 4))
    raw /= np.linalg.norm(raw, axis=1, keepdims=True)
    R = np.array([_rotation(q) for q in raw])
    R[:4] = [np.eye(3), np.diag([1.0, -1, -1]), np.diag([-1.0, 1, -1]), np.diag([-1.0, -1, 1])]
    quats = quaternions_xyzw(R)
    for k in range(len(R)):
        np.testing.assert_allclose(_rotation(quats[k]), R[k], atol=1e-12)
    assert np.all(np.sum(quats[1:] * quats[:-1], axis=1) >= 0)  # no sign flips between keys


def test_superellipsoid_and_tube_meshes_lie_on_their_surfaces() -> None:
    from mmplan.report.shapes import footprint, superellipsoid_mesh, tube_mesh
    from mmplan.scene import Box, SuperellipsoidModel

    for exponents in ((1.0, 1.0), (0.3, 0.8), (1.5, 0.2)):
        model = SuperellipsoidModel((1.0, -2.0, 0.5), (0.3, 0.2, 0.1), exponents, 0.4)
        vertices, faces = superellipsoid_mesh(model, 24, 12)
        np.testing.assert_allclose(model.implicit(vertices), 1.0, atol=1e-9)
        assert faces.max() < len(vertices) and faces.shape[1] == 3
    line = np.column_stack([np.linspace(0, 1, 20), np.sin(np.linspace(0, 3, 20)), np.ones(20)])
    vertices, _ = tube_mesh(line, 0.01, sides=6)
    rings = vertices.reshape(20, 6, 3)
    np.testing.assert_allclose(np.linalg.norm(rings - line[:, None, :], axis=2), 0.01)
    box = footprint(Box((1.0, 2.0, 0.5), (0.4, 0.2, 1.0), np.pi / 2))
    np.testing.assert_allclose(np.ptp(box, axis=0), [0.2, 0.4], atol=1e-12)  # turned 90 deg


def test_mesh_visuals_reach_meshcat_as_triangles_or_mesh_files() -> None:
    """The hook for URDF link meshes: a MESH piece given as triangles or as a file's text."""
    from mmplan.report.meshcat_commands import Commands, path
    from mmplan.report.scene3d import _geometry
    from mmplan.report.visuals import Visual, VisualKind

    triangles = Visual("hull", VisualKind.MESH, (2.0, 2.0, 2.0), vertices=np.eye(3),
                       faces=np.array([[0, 1, 2]]))
    obj = Visual("shell", VisualKind.MESH, (1.0, 1.0, 1.0),
                 mesh_data="v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", mesh_format="obj")
    cmds = Commands()
    for piece in (triangles, obj):
        geometry, pose = _geometry(piece)
        cmds.mesh(path("robot", "link", piece.name), geometry, "#808080", 1.0, pose)
    decoded = [umsgpack.unpackb(c) for c in cmds.packed]
    objects, poses = _objects(decoded), _transforms(decoded)
    hull = objects["/robot/link/hull"]["geometries"][0]
    assert hull["type"] == "BufferGeometry"
    np.testing.assert_allclose(np.diag(poses["/robot/link/hull"])[:3], 2.0)  # its scale
    shell = objects["/robot/link/shell"]["geometries"][0]
    assert (shell["type"], shell["format"]) == ("_meshfile_geometry", "obj")
    assert shell["data"].startswith("v 0 0 0")
