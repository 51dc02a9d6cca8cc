"""URDF robots drawn from their own visual geometry: every visual sits where Pinocchio puts it
(held links in place), meshes are read from STL, OBJ and COLLADA with their scale, units, up
axis and colours, and the robot's triangles reach meshcat as indexed meshes."""

from __future__ import annotations

import struct
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import umsgpack

from mmplan.report import meshes
from mmplan.report.visuals import VisualKind


def _pinocchio() -> Any:
    return pytest.importorskip("pinocchio", reason="URDF robots need Pinocchio (mmplan[urdf])")


def _robot(name: str) -> Any:
    _pinocchio()
    from mmplan.errors import InputError
    from mmplan.robot import get_robot

    try:
        return get_robot(name)
    except InputError as exc:
        pytest.skip(f"{name}: {exc}")


def _world(robot: Any, q: np.ndarray, bodies: list[str]) -> dict[str, np.ndarray]:
    from mmplan.report.scene3d import body_transforms

    T = body_transforms(robot, bodies, q[None, :])[0]
    return dict(zip(bodies, T, strict=True))


def _planar(x: float, y: float, theta: float) -> np.ndarray:
    T = np.eye(4)
    c, s = np.cos(theta), np.sin(theta)
    T[:2, :2] = [[c, -s], [s, c]]
    T[:2, 3] = (x, y)
    return T


def test_tiago_visuals_sit_where_pinocchio_puts_them(rng: np.random.Generator) -> None:
    """At a random q every visual of TIAGo's URDF (65: meshes, boxes, cylinders, spheres;
    the held head, casters and hand included) is where Pinocchio's visual geometry model of
    the whole URDF puts it, with the held joints at their held values."""
    pin = _pinocchio()
    from mmplan.robot.urdf.visuals import visual_elements

    robot = _robot("tiago")
    urdf = str(robot.source.urdf)
    model = pin.buildModelFromUrdf(urdf)
    geometry = pin.buildGeomFromUrdf(model, urdf, pin.GeometryType.VISUAL,
                                     package_dirs=[str(p) for p in Path(urdf).parents])
    lo, hi = robot.limits.joint_min, robot.limits.joint_max
    q = np.concatenate([rng.uniform(-2, 2, 3), rng.uniform(-3, 3, 2), rng.uniform(lo, hi)])
    full = pin.neutral(model)
    values = {**robot.source.held, **dict(zip(robot.coordinates, q, strict=True))}
    for jid in range(1, model.njoints):
        name, i = str(model.names[jid]), int(model.idx_qs[jid])
        if name in values:
            if model.joints[jid].nq == 2:
                full[i : i + 2] = np.cos(values[name]), np.sin(values[name])
            else:
                full[i] = values[name]
    data, gdata = model.createData(), geometry.createData()
    pin.forwardKinematics(model, data, full)
    pin.updateGeometryPlacements(model, data, geometry, gdata)
    platform = _planar(*q[:3])

    elements = visual_elements(robot)
    world = _world(robot, q, list(elements))
    matched = 0
    for body, items in elements.items():
        seen: dict[str, int] = {}
        for element in items:
            k = seen.get(element.link, 0)
            seen[element.link] = k + 1
            gid = geometry.getGeometryId(f"{element.link}_{k}")
            expected = platform @ np.asarray(gdata.oMg[gid].homogeneous)
            np.testing.assert_allclose(world[body] @ element.pose, expected, atol=1e-9,
                                       err_msg=f"{element.link} in {body}")
            obj = geometry.geometryObjects[gid]
            if element.kind == "mesh":
                assert Path(obj.meshPath).resolve() == element.mesh.resolve()
                np.testing.assert_allclose(element.size, obj.meshScale)
            np.testing.assert_allclose(element.rgba, obj.meshColor, atol=1e-6)
            matched += 1
    assert matched == geometry.ngeoms == 65
    assert {e.link for e in elements["torso_lift_link"]} == {"torso_lift_link", "head_1_link",
                                                             "head_2_link"}


def test_tiago_is_drawn_with_its_meshes_in_its_bodies() -> None:
    from mmplan.report.visuals import robot_looks

    robot = _robot("tiago")
    looks = robot_looks(robot)
    assert set(looks.bodies) == {"platform", "wheel_left_link", "wheel_right_link",
                                 "torso_lift_link", *(f"arm_{k}_link" for k in range(1, 8))}
    pieces = {b: {p.name: p for p in v} for b, v in looks.bodies.items()}
    base = pieces["platform"]["base_link"]
    assert base.kind is VisualKind.MESH and base.color == "#ffffff"
    assert pieces["platform"]["base_cover_link"].color == "#ff820c"  # URDF "Orange"
    column = pieces["platform"]["torso_fixed_column_link"]  # a URDF box
    assert column.kind is VisualKind.BOX and column.size == (0.18, 0.2, 0.55)
    (stl,) = meshes.read_mesh(Path(str(robot.source.urdf)).parents[1] / "meshes" / "pmb2"
                              / "base" / "base.stl")
    np.testing.assert_allclose(base.vertices.min(axis=0), stl.vertices.min(axis=0))
    np.testing.assert_allclose(base.vertices.max(axis=0), stl.vertices.max(axis=0))
    # every triangle kept (under the budget) but one that repeats another or has no area
    assert len(stl.faces) - 1 == len(base.faces)
    assert base.faces.max() < len(base.vertices)
    triangles = sum(len(p.faces) for v in looks.bodies.values() for p in v
                    if p.faces is not None)
    assert triangles > 100_000
    assert f"({triangles:,} triangles)" in looks.legend
    tool = pieces["arm_7_link"]["tool"]
    np.testing.assert_allclose(tool.pose[:3, 3], robot.end_effector.offset)


def test_arm_only_urdf_gets_its_platform_box_and_dae_colours() -> None:
    """ur5-omni: the UR5's DAE meshes keep their own colours (the URDF has no materials);
    the platform box the UR5 is mounted on comes from the platform's inertia."""
    from mmplan.report.visuals import robot_looks

    looks = robot_looks(_robot("ur5-omni"))
    box = {p.name: p for p in looks.bodies["platform"]}["body"]
    assert box.kind is VisualKind.BOX
    np.testing.assert_allclose(box.size, (0.8, 0.6, 0.4), atol=1e-9)
    np.testing.assert_allclose(box.pose[:3, 3], (0.0, 0.0, 0.2), atol=1e-9)
    colours = {p.color for p in looks.bodies["upper_arm_link"]}
    assert len(colours) == 4 and "#405968" in colours  # UR blue, greys
    assert "platform box" in looks.legend


def _stl_binary(triangles: np.ndarray) -> bytes:
    out = bytearray(b"\0" * 80 + struct.pack("<I", len(triangles)))
    for tri in triangles:
        out += struct.pack("<3f", 0, 0, 0) + tri.astype("<f4").tobytes() + b"\0\0"
    return bytes(out)


CUBE = np.array([  # unit cube, 12 triangles, counter-clockwise from outside
    [[0, 0, 0], [0, 1, 0], [1, 1, 0]], [[0, 0, 0], [1, 1, 0], [1, 0, 0]],
    [[0, 0, 1], [1, 0, 1], [1, 1, 1]], [[0, 0, 1], [1, 1, 1], [0, 1, 1]],
    [[0, 0, 0], [1, 0, 0], [1, 0, 1]], [[0, 0, 0], [1, 0, 1], [0, 0, 1]],
    [[0, 1, 0], [0, 1, 1], [1, 1, 1]], [[0, 1, 0], [1, 1, 1], [1, 1, 0]],
    [[0, 0, 0], [0, 0, 1], [0, 1, 1]], [[0, 0, 0], [0, 1, 1], [0, 1, 0]],
    [[1, 0, 0], [1, 1, 0], [1, 1, 1]], [[1, 0, 0], [1, 1, 1], [1, 0, 1]],
], dtype=float) - 0.5

DAE = """<?xml version="1.0"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="centimeter" meter="0.01"/><up_axis>Y_UP</up_axis></asset>
  <library_effects><effect id="green-fx"><profile_COMMON><technique sid="t"><lambert>
    <diffuse><color>0 0.5 0 1</color></diffuse></lambert></technique></profile_COMMON></effect>
  </library_effects>
  <library_materials><material id="green"><instance_effect url="#green-fx"/></material>
  </library_materials>
  <library_geometries><geometry id="quad"><mesh>
    <source id="p"><float_array id="pa" count="12">0 0 0 10 0 0 10 0 10 0 0 10</float_array>
      <technique_common><accessor source="#pa" count="4" stride="3"/></technique_common></source>
    <vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
    <polylist material="m" count="1"><input semantic="VERTEX" source="#v" offset="0"/>
      <vcount>4</vcount><p>0 1 2 3</p></polylist>
  </mesh></geometry></library_geometries>
  <library_visual_scenes><visual_scene id="s"><node id="n"><translate>0 10 0</translate>
    <instance_geometry url="#quad"><bind_material><technique_common>
      <instance_material symbol="m" target="#green"/></technique_common></bind_material>
    </instance_geometry></node></visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#s"/></scene>
</COLLADA>
"""

INERTIAL = ('<inertial><mass value="{m}"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" '
            'ixz="0" iyz="0"/></inertial>')

TOY = f"""<?xml version="1.0"?>
<robot name="toy">
  <material name="red"><color rgba="1 0 0 1"/></material>
  <link name="base">{INERTIAL.format(m=10)}
    <visual><origin xyz="0 0 0.1"/><geometry>
      <mesh filename="package://toy/meshes/cube.stl" scale="0.5 0.5 0.2"/></geometry>
      <material name="red"/></visual>
    <visual><geometry><mesh filename="package://toy/meshes/missing.stl"/></geometry></visual>
  </link>
  <joint name="pan" type="revolute"><parent link="base"/><child link="arm"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <link name="arm">{INERTIAL.format(m=1)}
    <visual><origin xyz="0.2 0 0" rpy="0 1.5707963267948966 0"/><geometry>
      <cylinder radius="0.02" length="0.4"/></geometry>
      <material name="blue"><color rgba="0 0 1 0.5"/></material></visual></link>
  <joint name="tilt" type="revolute"><parent link="arm"/><child link="hand"/>
    <origin xyz="0.4 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="10" velocity="1"/></joint>
  <link name="hand">{INERTIAL.format(m=0.5)}
    <visual><geometry><mesh filename="../meshes/quad.dae"/></geometry></visual></link>
  <joint name="sensor" type="revolute"><parent link="base"/><child link="mast"/>
    <origin xyz="0 0 0.5"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <link name="mast">{INERTIAL.format(m=0.2)}
    <visual><origin xyz="0.1 0 0"/><geometry><mesh filename="package://toy/meshes/fan.obj"/>
      </geometry></visual></link>
</robot>
"""


def test_a_urdf_with_every_kind_of_visual(tmp_path: Path) -> None:
    """STL (scaled, named material), a cylinder (inline colour, alpha), a DAE (cm, Y_UP, node
    transform, its own colour), an OBJ on a held joint (drawn at its held value on the
    platform), and a missing mesh (left out, named in the legend)."""
    _pinocchio()
    from mmplan.report.visuals import robot_looks
    from mmplan.robot.urdf import load_urdf_robot

    root = tmp_path / "toy"
    (root / "meshes").mkdir(parents=True)
    (root / "urdf").mkdir()
    (root / "meshes" / "cube.stl").write_bytes(_stl_binary(CUBE))
    (root / "meshes" / "quad.dae").write_text(DAE)
    (root / "meshes" / "fan.obj").write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    urdf = root / "urdf" / "toy.urdf"
    urdf.write_text(TOY)
    robot = load_urdf_robot(urdf, platform={"kind": "omnidirectional"}, end_effector="hand",
                            locked={"sensor": 0.5}, collision=None)
    looks = robot_looks(robot)
    pieces = {b: {p.name: p for p in v} for b, v in looks.bodies.items()}
    assert set(pieces) == {"platform", "arm", "hand"}

    cube = pieces["platform"]["base"]
    assert cube.color == "#ff0000" and cube.kind is VisualKind.MESH
    np.testing.assert_allclose(np.ptp(cube.vertices, axis=0), (0.5, 0.5, 0.2))
    assert (len(cube.vertices), len(cube.faces)) == (24, 12)  # split at the cube's edges
    np.testing.assert_allclose(cube.pose[:3, 3], (0, 0, 0.1))

    fan = pieces["platform"]["mast"]  # held at 0.5 rad about z, 0.5 m up, 0.1 m out
    c, s = np.cos(0.5), np.sin(0.5)
    np.testing.assert_allclose(fan.pose[:3, 3], (0.1 * c, 0.1 * s, 0.5), atol=1e-12)
    np.testing.assert_allclose(fan.pose[:3, :3], [[c, -s, 0], [s, c, 0], [0, 0, 1]],
                               atol=1e-12)
    assert len(fan.faces) == 2  # the quad as a fan

    rod = pieces["arm"]["arm"]
    assert rod.kind is VisualKind.CYLINDER and rod.size == (0.02, 0.4)
    assert (rod.color, rod.opacity) == ("#0000ff", 0.5)
    np.testing.assert_allclose(rod.pose[:3, 2], (1, 0, 0), atol=1e-12)  # along the link

    quad = pieces["hand"]["hand"]
    assert quad.color == "#008000"  # the DAE's own diffuse colour
    np.testing.assert_allclose(quad.vertices.min(axis=0), (0.0, -0.1, 0.1), atol=1e-12)
    np.testing.assert_allclose(quad.vertices.max(axis=0), (0.1, 0.0, 0.1), atol=1e-12)

    assert "tool" in pieces["hand"]
    assert "Not drawn (unreadable mesh files): base: package://toy/meshes/missing.stl " \
           "(missing)." in looks.legend


def test_a_urdf_given_as_text_is_drawn_from_its_model() -> None:
    _pinocchio()
    from mmplan.report.visuals import BUILTIN_LEGEND, robot_looks
    from mmplan.robot.urdf import load_urdf_robot

    robot = load_urdf_robot(TOY.replace("package://toy/meshes/", ""),
                            platform={"kind": "omnidirectional"}, end_effector="hand",
                            collision=None)
    looks = robot_looks(robot)
    assert looks.legend == BUILTIN_LEGEND and "platform" in looks.bodies


def test_mesh_readers_and_processing() -> None:
    ascii_stl = "solid c\n" + "".join(
        "facet normal 0 0 0\nouter loop\n" + "".join(f"vertex {x} {y} {z}\n" for x, y, z in tri)
        + "endloop\nendfacet\n" for tri in CUBE) + "endsolid c\n"
    binary = meshes.read_stl(_stl_binary(CUBE))
    text = meshes.read_stl(ascii_stl.encode())
    np.testing.assert_allclose(binary.vertices, text.vertices)
    vertices, faces = meshes.weld(text.vertices, text.faces)
    assert (len(vertices), len(faces)) == (8, 12)
    split_v, split_f = meshes.split_creases(vertices, faces)
    assert (len(split_v), len(split_f)) == (24, 12)
    smooth_v, _ = meshes.split_creases(vertices, faces, crease_deg=100.0)
    assert len(smooth_v) == 8  # every edge of a cube turns by 90 deg < 100
    a, b, c = (split_v[split_f[:, k]] for k in range(3))
    outward = np.einsum("ij,ij->i", np.cross(b - a, c - a), (a + b + c) / 3)
    assert np.all(outward > 0)  # winding kept

    sphere = np.random.default_rng(3).normal(size=(4000, 3))
    sphere /= np.linalg.norm(sphere, axis=1, keepdims=True)
    from scipy.spatial import ConvexHull

    hull = ConvexHull(sphere)
    fine_v, fine_f = meshes.weld(sphere, hull.simplices)
    coarse_v, coarse_f = meshes.cluster(fine_v, fine_f, 0.2)
    assert len(coarse_f) < len(fine_f) / 4 and coarse_f.max() < len(coarse_v)
    np.testing.assert_allclose(np.linalg.norm(coarse_v, axis=1), 1.0, atol=0.05)

    with pytest.raises(meshes.MeshError, match="unknown mesh format"):
        meshes.read_mesh(Path(__file__))


def test_indexed_meshes_use_16_bit_indices_when_they_can() -> None:
    from mmplan.report.meshcat_commands import IndexedMesh

    small = IndexedMesh(np.zeros((10, 3)), np.array([[0, 1, 2]])).lower(None)
    index = small["data"]["index"]
    assert index["type"] == "Uint16Array" and index["array"].type == 0x14
    assert np.frombuffer(index["array"].data, dtype="<u2").tolist() == [0, 1, 2]
    big = IndexedMesh(np.zeros((70000, 3)), np.array([[0, 1, 69999]])).lower(None)
    assert big["data"]["index"]["type"] == "Uint32Array"
    position = big["data"]["attributes"]["position"]
    assert position["array"].type == 0x17 and len(position["array"].data) == 70000 * 12
    umsgpack.packb(big)  # packs as meshcat expects


def test_a_urdf_whose_meshes_are_all_missing_is_drawn_from_its_model(tmp_path: Path) -> None:
    _pinocchio()
    from mmplan.report.visuals import BUILTIN_LEGEND, robot_looks
    from mmplan.robot.urdf import load_urdf_robot

    urdf = tmp_path / "bare.urdf"
    urdf.write_text(f"""<robot name="bare">
  <link name="base">{INERTIAL.format(m=5)}</link>
  <joint name="pan" type="revolute"><parent link="base"/><child link="arm"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <link name="arm">{INERTIAL.format(m=1)}
    <visual><geometry><mesh filename="package://nowhere/arm.dae"/></geometry></visual></link>
</robot>""")
    robot = load_urdf_robot(urdf, platform={"kind": "omnidirectional"}, end_effector="arm",
                            collision=None)
    looks = robot_looks(robot)
    assert looks.legend == BUILTIN_LEGEND + " Not drawn (unreadable mesh files): arm: " \
        "package://nowhere/arm.dae (missing)."
    assert {p.name for p in looks.bodies["platform"]} == {"body"}
