"""Mesh files as triangles for the 3D view: STL, OBJ and COLLADA (DAE) readers, welding,
decimation by vertex clustering and splitting at creases.

The report turns every mesh into indexed triangles in Python (nothing is parsed in the
browser): its size is then known and bounded, identical vertices are shared, and the three.js
viewer gets normals that are smooth across gentle bends and sharp at creases (a vertex is
split where the faces around it turn by more than :data:`CREASE_DEG`; the viewer averages the
face normals at each vertex, ``computeVertexNormals``).

Readers (each returns :class:`MeshPart` pieces in the file's own frame, in metres):

* STL, binary or ASCII;
* OBJ: ``v`` and ``f`` lines (polygons as fans), materials ignored;
* COLLADA 1.4/1.5: ``<triangles>``, ``<polylist>`` and ``<polygons>`` of every
  ``<instance_geometry>`` in the visual scene, with the node transforms (``matrix``,
  ``translate``, ``rotate``, ``scale``, nested and ``instance_node``), the ``<unit meter>``
  scale and the ``<up_axis>`` (a Y_UP or X_UP file is turned to z up, the convention of URDF
  and ROS; COLLADA's default is Y_UP); each bound material's diffuse colour (a texture gives
  no colour).
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from pathlib import Path
from xml.etree import ElementTree

import numpy as np

from mmplan.arrays import Array

#: Faces around a vertex turning by more than this get their own copy of it (sharp edge).
CREASE_DEG = 40.0


@dataclass(frozen=True)
class MeshPart:
    """Triangles of one colour.

    Attributes:
        vertices: (V, 3) [m].
        faces: (F, 3) vertex indices, counter-clockwise seen from outside.
        rgba: The file's own colour (COLLADA material), None where it has none.
    """

    vertices: Array
    faces: np.ndarray
    rgba: tuple[float, float, float, float] | None = None


class MeshError(ValueError):
    """A mesh file that cannot be read (unknown format, malformed contents)."""


def read_mesh(path: Path) -> list[MeshPart]:
    """The triangles of a mesh file (format from its suffix: .stl, .obj, .dae).

    Raises:
        MeshError: unknown format or malformed contents.
        OSError: the file cannot be read.
    """
    suffix = path.suffix.lower()
    data = path.read_bytes()
    try:
        if suffix == ".stl":
            return [read_stl(data)]
        if suffix == ".obj":
            return [read_obj(data.decode("utf-8", errors="replace"))]
        if suffix == ".dae":
            return read_dae(data)
    except (ValueError, IndexError, KeyError, struct.error, ElementTree.ParseError) as exc:
        if isinstance(exc, MeshError):
            raise
        raise MeshError(f"{path.name}: {exc}") from None
    raise MeshError(f"{path.name}: unknown mesh format {suffix!r} (stl, obj, dae)")


def read_stl(data: bytes) -> MeshPart:
    """Binary or ASCII STL as a triangle soup (vertices not shared)."""
    if len(data) >= 84:
        count = struct.unpack_from("<I", data, 80)[0]
        if len(data) == 84 + 50 * count:
            record = np.dtype([("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
            triangles = np.frombuffer(data, dtype=record, count=count, offset=84)["v"]
            return _soup(triangles.reshape(-1, 3).astype(float))
    text = data.decode("ascii", errors="replace")
    if not text.lstrip().lower().startswith("solid"):
        raise MeshError("neither a binary nor an ASCII STL")
    values = [line.split()[1:4] for line in text.splitlines()
              if line.lstrip().lower().startswith("vertex")]
    points = np.array(values, dtype=float).reshape(-1, 3)
    return _soup(points[: len(points) // 3 * 3])


def _soup(points: Array) -> MeshPart:
    faces = np.arange(len(points)).reshape(-1, 3)
    return MeshPart(points, faces)


def read_obj(text: str) -> MeshPart:
    """Wavefront OBJ: ``v`` and ``f`` (1-based or negative indices), polygons as fans."""
    vertices: list[list[float]] = []
    faces: list[tuple[int, int, int]] = []
    for line in text.splitlines():
        fields = line.split()
        if not fields:
            continue
        if fields[0] == "v":
            vertices.append([float(x) for x in fields[1:4]])
        elif fields[0] == "f":
            ids = [int(f.split("/")[0]) for f in fields[1:]]
            ids = [i - 1 if i > 0 else len(vertices) + i for i in ids]
            faces.extend((ids[0], ids[k], ids[k + 1]) for k in range(1, len(ids) - 1))
    return MeshPart(np.array(vertices, dtype=float).reshape(-1, 3),
                    np.array(faces, dtype=np.int64).reshape(-1, 3))


# COLLADA ------------------------------------------------------------------------------------


def _local(tag: str) -> str:
    return tag.rsplit("}", 1)[-1]


def _strip_namespaces(root: ElementTree.Element) -> None:
    for element in root.iter():
        element.tag = _local(element.tag)


def _floats(text: str | None) -> Array:
    return np.array((text or "").split(), dtype=float)


def _ints(text: str | None) -> np.ndarray:
    return np.array((text or "").split(), dtype=np.int64)


def _ref(url: str | None) -> str:
    return (url or "").lstrip("#")


def _node_transform(node: ElementTree.Element) -> Array:
    """The node's transform elements multiplied in document order (4, 4)."""
    T = np.eye(4)
    for child in node:
        tag = child.tag
        if tag == "matrix":
            T = T @ _floats(child.text).reshape(4, 4)
        elif tag == "translate":
            M = np.eye(4)
            M[:3, 3] = _floats(child.text)[:3]
            T = T @ M
        elif tag == "rotate":
            x, y, z, deg = _floats(child.text)[:4]
            M = np.eye(4)
            M[:3, :3] = _axis_angle(np.array([x, y, z]), math.radians(deg))
            T = T @ M
        elif tag == "scale":
            T = T @ np.diag([*_floats(child.text)[:3], 1.0])
    return T


def _axis_angle(axis: Array, angle: float) -> Array:
    n = float(np.linalg.norm(axis))
    if n == 0.0:
        return np.eye(3)
    x, y, z = axis / n
    K = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def _up_to_z(up: str) -> Array:
    """Rotation (4, 4) turning a file's up axis onto z (x stays forward for Y_UP)."""
    T = np.eye(4)
    if up == "Y_UP":  # (x, y, z) -> (x, -z, y)
        T[:3, :3] = [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]
    elif up == "X_UP":  # (x, y, z) -> (-y, x, z) then x up: x -> z
        T[:3, :3] = [[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]
    return T


class _Collada:
    """Index of one COLLADA document: elements by id, the diffuse colour of each material."""

    def __init__(self, root: ElementTree.Element) -> None:
        self.root = root
        self.by_id = {e.get("id"): e for e in root.iter() if e.get("id") is not None}

    def material_rgba(self, material_id: str) -> tuple[float, float, float, float] | None:
        material = self.by_id.get(material_id)
        if material is None or material.tag != "material":
            return None
        effect_ref = material.find("instance_effect")
        effect = self.by_id.get(_ref(effect_ref.get("url") if effect_ref is not None else None))
        if effect is None:
            return None
        for diffuse in effect.iter("diffuse"):
            color = diffuse.find("color")
            if color is not None:
                c = _floats(color.text)
                if len(c) >= 3:
                    alpha = float(c[3]) if len(c) >= 4 else 1.0
                    return (float(c[0]), float(c[1]), float(c[2]), alpha)
        return None

    def positions(self, mesh: ElementTree.Element, source_id: str) -> Array:
        """Positions (P, 3) of a ``<vertices>`` or ``<source>`` element."""
        element = self.by_id[source_id]
        if element.tag == "vertices":
            for inp in element.findall("input"):
                if inp.get("semantic") == "POSITION":
                    return self.positions(mesh, _ref(inp.get("source")))
            raise MeshError(f"<vertices id={source_id!r}> has no POSITION input")
        values = _floats(element.find("float_array").text)  # type: ignore[union-attr]
        accessor = element.find("technique_common/accessor")
        stride = int(accessor.get("stride", "3")) if accessor is not None else 3
        return values[: len(values) // stride * stride].reshape(-1, stride)[:, :3]

    def geometry(self, geometry_id: str) -> list[tuple[str, Array, np.ndarray]]:
        """(material symbol, positions, faces) of each primitive of a ``<geometry>``."""
        geometry = self.by_id.get(geometry_id)
        mesh = geometry.find("mesh") if geometry is not None else None
        if mesh is None:
            return []
        out = []
        for primitive in mesh:
            if primitive.tag not in ("triangles", "polylist", "polygons"):
                continue
            inputs = primitive.findall("input")
            vertex = [i for i in inputs if i.get("semantic") == "VERTEX"]
            if not vertex:
                continue
            stride = 1 + max(int(i.get("offset", "0")) for i in inputs)
            offset = int(vertex[0].get("offset", "0"))
            points = self.positions(mesh, _ref(vertex[0].get("source")))
            if primitive.tag == "polygons":
                polygons = [_ints(p.text)[offset::stride] for p in primitive.findall("p")]
                faces = _fans(polygons)
            else:
                index = _ints(primitive.findtext("p"))[offset::stride]
                if primitive.tag == "triangles":
                    faces = index[: len(index) // 3 * 3].reshape(-1, 3)
                else:
                    counts = _ints(primitive.findtext("vcount"))
                    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
                    faces = _fans([index[s : s + c] for s, c in zip(starts, counts, strict=True)])
            out.append((primitive.get("material", ""), points, faces))
        return out


def _fans(polygons: list[np.ndarray]) -> np.ndarray:
    faces = [(p[0], p[k], p[k + 1]) for p in polygons for k in range(1, len(p) - 1)]
    return np.array(faces, dtype=np.int64).reshape(-1, 3)


def read_dae(data: bytes) -> list[MeshPart]:
    """COLLADA triangles in the file's frame turned to z up, in metres, one part per material."""
    root = ElementTree.fromstring(data)
    _strip_namespaces(root)
    doc = _Collada(root)
    unit = root.find("asset/unit")
    scale = float(unit.get("meter", "1")) if unit is not None else 1.0
    up = (root.findtext("asset/up_axis") or "Y_UP").strip()
    top = _up_to_z(up) @ np.diag([scale, scale, scale, 1.0])
    parts: list[MeshPart] = []

    def visit(node: ElementTree.Element, parent: Array, depth: int) -> None:
        if depth > 64:
            raise MeshError("node hierarchy deeper than 64 levels (a cycle?)")
        T = parent @ _node_transform(node)
        for child in node:
            if child.tag == "node":
                visit(child, T, depth + 1)
            elif child.tag == "instance_node":
                target = doc.by_id.get(_ref(child.get("url")))
                if target is not None:
                    visit(target, T, depth + 1)
            elif child.tag == "instance_geometry":
                bound = {m.get("symbol"): _ref(m.get("target"))
                         for m in child.iter("instance_material")}
                for symbol, points, faces in doc.geometry(_ref(child.get("url"))):
                    world = points @ T[:3, :3].T + T[:3, 3]
                    rgba = doc.material_rgba(bound.get(symbol, symbol))
                    parts.append(MeshPart(world, faces, rgba))

    scene_ref = root.find("scene/instance_visual_scene")
    scene = doc.by_id.get(_ref(scene_ref.get("url"))) if scene_ref is not None else None
    if scene is None:
        scene = root.find("library_visual_scenes/visual_scene")
    if scene is not None:
        for node in scene.findall("node"):
            visit(node, top, 0)
    else:  # no scene: every geometry as it is
        for geometry in root.iter("geometry"):
            for symbol, points, faces in doc.geometry(geometry.get("id", "")):
                world = points @ top[:3, :3].T
                parts.append(MeshPart(world, faces, doc.material_rgba(symbol)))
    return merge_by_colour(parts)


def merge_by_colour(parts: list[MeshPart]) -> list[MeshPart]:
    """Parts of equal colour joined into one (order of first appearance)."""
    groups: dict[tuple[float, ...] | None, list[MeshPart]] = {}
    for part in parts:
        if len(part.faces):
            groups.setdefault(part.rgba, []).append(part)
    out = []
    for rgba, group in groups.items():
        offsets = np.cumsum([0] + [len(p.vertices) for p in group])[:-1]
        faces = [p.faces + o for p, o in zip(group, offsets, strict=True)]
        out.append(MeshPart(np.concatenate([p.vertices for p in group]), np.concatenate(faces),
                            None if rgba is None else (rgba[0], rgba[1], rgba[2], rgba[3])))
    return out


# Processing ---------------------------------------------------------------------------------


def unique_rows(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distinct rows of a (N, k) array in sorted order and, per row, the index of its own
    (``np.unique(rows, axis=0, return_inverse=True)``, by a lexicographic sort: faster)."""
    if not len(rows):
        return rows, np.zeros(0, dtype=np.int64)
    order = np.lexsort(rows.T[::-1])
    ordered = rows[order]
    new = np.ones(len(rows), dtype=bool)
    new[1:] = np.any(ordered[1:] != ordered[:-1], axis=1)
    inverse = np.empty(len(rows), dtype=np.int64)
    inverse[order] = np.cumsum(new) - 1
    return ordered[new], inverse


def weld(vertices: Array, faces: np.ndarray) -> tuple[Array, np.ndarray]:
    """Identical vertices shared, unused ones dropped, faces with a repeated vertex dropped."""
    unique, inverse = unique_rows(vertices)
    return _compact(unique, inverse[faces])


def _compact(vertices: Array, faces: np.ndarray) -> tuple[Array, np.ndarray]:
    """Drop degenerate and repeated faces and the vertices no face uses."""
    f = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2])
              & (faces[:, 0] != faces[:, 2])]
    if len(f):
        index = np.arange(3)[None, :] + np.argmin(f, axis=1)[:, None]  # same cycle, min first
        _, inverse = unique_rows(np.take_along_axis(f, index % 3, axis=1))
        first = np.full(inverse.max() + 1, len(f))
        np.minimum.at(first, inverse, np.arange(len(f)))
        f = f[np.sort(first)]
    used, remap = np.unique(f, return_inverse=True)
    return vertices[used], remap.reshape(-1, 3)


def cluster(vertices: Array, faces: np.ndarray, cell: float) -> tuple[Array, np.ndarray]:
    """Vertex-clustering decimation: vertices in one cube of edge ``cell`` [m] become their
    mean; faces that collapse are dropped. Features smaller than a cell may vanish."""
    keys = np.floor(vertices / cell).astype(np.int64)
    _, inverse = unique_rows(keys)
    counts = np.bincount(inverse)
    means = np.zeros((len(counts), 3))
    np.add.at(means, inverse, vertices)
    means /= counts[:, None]
    return _compact(means, inverse[faces])


def split_creases(vertices: Array, faces: np.ndarray, crease_deg: float = CREASE_DEG
                  ) -> tuple[Array, np.ndarray]:
    """A copy of a vertex for each group of its faces whose normals lie within ``crease_deg``
    of the group's first face: the viewer's averaged normals then stay sharp at creases.
    Zero-area faces are dropped."""
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    normals = np.cross(b - a, c - a)
    length = np.linalg.norm(normals, axis=1)
    keep = length > 1e-18
    faces, normals = faces[keep], normals[keep] / length[keep, None]
    corner_vertex = faces.reshape(-1)
    corner_normal = np.repeat(normals, 3, axis=0)
    order = np.argsort(corner_vertex, kind="stable")
    group = np.full(len(corner_vertex), -1, dtype=np.int64)
    cos_limit = math.cos(math.radians(crease_deg))
    next_group = 0
    pending = order
    while len(pending):
        v = corner_vertex[pending]  # sorted: each vertex's pending corners together
        first = np.flatnonzero(np.r_[True, v[1:] != v[:-1]])
        seeds = np.repeat(pending[first], np.diff(np.r_[first, len(v)]))
        near = np.einsum("ij,ij->i", corner_normal[pending], corner_normal[seeds]) >= cos_limit
        near[first] = True
        ids = next_group + np.repeat(np.arange(len(first)), np.diff(np.r_[first, len(v)]))
        group[pending[near]] = ids[near]
        next_group += len(first)
        pending = pending[~near]
    corner = np.empty(next_group, dtype=np.int64)
    corner[group[::-1]] = np.arange(len(group))[::-1]  # the first corner of each group
    return vertices[corner_vertex[corner]], group.reshape(-1, 3)


def transform(vertices: Array, T: Array) -> Array:
    """Points (V, 3) moved by the homogeneous transform T (4, 4)."""
    return np.asarray(vertices @ T[:3, :3].T + T[:3, 3], dtype=float)
