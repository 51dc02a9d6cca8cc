"""meshcat command messages built offline, without meshcat's server.

meshcat's viewer (the three.js bundle shipped in the ``meshcat`` package) draws whatever
command messages it is handed: ``set_object``, ``set_transform``, ``set_property`` and
``set_animation``, each a msgpack-encoded dict. meshcat-python normally sends them through its
ZeroMQ server and asks the server for a static page (``Visualizer.static_html``); here the same
messages are built with meshcat's own geometry and command classes and packed with msgpack
(``umsgpack``, meshcat's dependency) into bytes that the report embeds, so no server, socket or
network is involved.

Two small departures from meshcat-python, both in the messages only:

* element uuids are numbered (``mmplan-000001``...) instead of ``uuid.uuid1()``, which embeds
  the host's network address and the time: the page is reproducible and reveals neither;
* animation tracks carry ``times`` and ``values`` as packed float32 arrays (three.js's own
  keyframe-track form, which its ``AnimationClip.parse`` reads directly) instead of one
  ``{time, value}`` dict per key: 10-20x smaller and faster to pack.
"""

from __future__ import annotations

import itertools
import sys
import warnings
from collections.abc import Iterator, Mapping, Sequence
from importlib import import_module
from importlib.util import find_spec
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np
import umsgpack

from mmplan.arrays import Array


def _meshcat_parts() -> dict[str, ModuleType]:
    """meshcat's geometry, commands, animation and path modules, loaded without running the
    package's ``__init__``, which imports meshcat's server (ZeroMQ, tornado, IPython: 0.3 s
    of the report's time, none of it used here). The package stands in sys.modules as a bare
    module only while its parts load; a later ``import meshcat`` runs the real ``__init__``,
    which finds them loaded."""
    names = ("geometry", "commands", "animation", "path")
    spec = find_spec("meshcat")
    where = list(spec.submodule_search_locations or ()) if spec is not None else []
    bare = "meshcat" not in sys.modules and bool(where)
    if bare:
        package = ModuleType("meshcat")
        package.__path__ = where
        sys.modules["meshcat"] = package
    try:
        with warnings.catch_warnings():  # meshcat's own package imports zmq (deprecations)
            warnings.simplefilter("ignore", DeprecationWarning)
            return {name: import_module(f"meshcat.{name}") for name in names}
    finally:
        if bare:
            del sys.modules["meshcat"]


if TYPE_CHECKING:
    from meshcat import geometry as g
    from meshcat.animation import Animation, AnimationClip
    from meshcat.commands import SetAnimation, SetObject, SetProperty, SetTransform
    from meshcat.path import Path
else:
    _meshcat = _meshcat_parts()
    g = _meshcat["geometry"]
    Animation = _meshcat["animation"].Animation
    AnimationClip = _meshcat["animation"].AnimationClip
    SetAnimation = _meshcat["commands"].SetAnimation
    SetObject = _meshcat["commands"].SetObject
    SetProperty = _meshcat["commands"].SetProperty
    SetTransform = _meshcat["commands"].SetTransform
    Path = _meshcat["path"].Path

#: meshcat's geometry classes (Box, Cylinder, Sphere, TriangularMeshGeometry, ...).
geometry = g

FLOAT32 = 0x17  # msgpack extension code of a Float32Array (meshcat / msgpack-lite)
UINT16 = 0x14  # ... of a Uint16Array
UINT32 = 0x16  # ... of a Uint32Array


def path(*parts: str) -> Any:
    """A meshcat scene path from its elements (``path("robot", "link1")`` is /robot/link1)."""
    return Path(tuple(parts))


class Commands:
    """An ordered list of packed meshcat commands, with reproducible element uuids."""

    def __init__(self) -> None:
        self.packed: list[bytes] = []
        self._ids: Iterator[int] = itertools.count(1)

    def _name(self, *elements: Any) -> None:
        for element in elements:
            element.uuid = f"mmplan-{next(self._ids):06d}"

    def _send(self, command: Any) -> None:
        self.packed.append(umsgpack.packb(command.lower()))

    def set_object(self, where: Any, obj: Any) -> None:
        """``set_object`` with a meshcat ``Object`` (Mesh, Points, LineSegments, ...)."""
        self._name(obj, obj.geometry, obj.material)
        self._send(SetObject(obj, path=where))

    def mesh(self, where: Any, geometry: Any, color: str, opacity: float = 1.0,
             pose: Array | None = None) -> None:
        """A lit mesh of one colour, optionally placed by ``pose`` (4, 4) relative to its node."""
        material = g.MeshLambertMaterial(color=hex_color(color), opacity=opacity)
        self.set_object(where, g.Mesh(geometry, material))
        if pose is not None:
            self.set_transform(where, pose)

    def set_transform(self, where: Any, matrix: Array) -> None:
        """``set_transform`` with a homogeneous matrix (4, 4)."""
        self._send(SetTransform(np.asarray(matrix, dtype=float), where))

    def set_property(self, where: Any, key: str, value: Any) -> None:
        """``set_property`` (``visible``, ``position``, ``top_color``, ...)."""
        self._send(SetProperty(key, value, where))

    def set_animation(self, clips: Mapping[Any, Sequence[ArrayTrack]]) -> None:
        """``set_animation`` of the given nodes' tracks; loaded paused (the page starts it)."""
        animation = Animation()
        for where, tracks in clips.items():
            animation.clips[where] = AnimationClip(tracks={t.name: t for t in tracks}, fps=1)
        self._send(SetAnimation(animation, play=False, repetitions=1))


class IndexedMesh(g.Geometry):
    """Indexed triangles as a three.js BufferGeometry: positions as float32, indices as
    uint16 where there are fewer than 65,536 vertices (else uint32). No normals: the viewer
    averages the face normals at each vertex (meshcat calls ``computeVertexNormals``)."""

    def __init__(self, vertices: Array, faces: np.ndarray) -> None:
        super().__init__()
        self.vertices = np.ascontiguousarray(vertices, dtype=np.float32).reshape(-1, 3)
        index_type = np.uint16 if len(self.vertices) < 65536 else np.uint32
        self.faces = np.ascontiguousarray(faces, dtype=index_type).reshape(-1, 3)

    def lower(self, object_data: Any) -> dict[str, Any]:
        index_type, code = (("Uint16Array", UINT16) if self.faces.dtype == np.uint16
                            else ("Uint32Array", UINT32))
        return {
            "uuid": self.uuid,
            "type": "BufferGeometry",
            "data": {
                "attributes": {"position": {
                    "itemSize": 3, "type": "Float32Array", "normalized": False,
                    "array": umsgpack.Ext(FLOAT32, self.vertices.tobytes())}},
                "index": {"itemSize": 1, "type": index_type, "normalized": False,
                          "array": umsgpack.Ext(code, self.faces.tobytes())},
            },
        }


class ArrayTrack:
    """A three.js keyframe track (``.position`` vector3, ``.quaternion`` quaternion, ...).

    Args:
        name: Animated property (``position``, ``quaternion``, ``scale``).
        jstype: three.js track type (``vector3``, ``quaternion``).
        times: Key times (K,) [s].
        values: Values (K, d), flattened row by row.
    """

    def __init__(self, name: str, jstype: str, times: Array, values: Array) -> None:
        self.name = name
        self.jstype = jstype
        self.times = np.ascontiguousarray(times, dtype=np.float32)
        self.values = np.ascontiguousarray(values, dtype=np.float32).reshape(-1)

    def lower(self) -> dict[str, Any]:
        return {
            "name": "." + self.name,
            "type": self.jstype,
            "times": umsgpack.Ext(FLOAT32, self.times.tobytes()),
            "values": umsgpack.Ext(FLOAT32, self.values.tobytes()),
        }


def hex_color(color: str) -> int:
    """``#rrggbb`` as the integer three.js expects."""
    return int(color.lstrip("#"), 16)


def rgb(color: str) -> list[int]:
    """``#rrggbb`` as [r, g, b] (0-255)."""
    value = hex_color(color)
    return [(value >> 16) & 255, (value >> 8) & 255, value & 255]


def quaternions_xyzw(R: Array) -> Array:
    """Unit quaternions (K, 4) as (x, y, z, w) of rotation matrices (K, 3, 3).

    Shepperd's method: the largest of w, x, y, z is found first, so no division is by a
    small number; signs are then made continuous along K (q and -q are the same rotation,
    and three.js interpolates between neighbouring keys).
    """
    R = np.asarray(R, dtype=float)
    trace = np.trace(R, axis1=1, axis2=2)
    diag = np.stack([trace, R[:, 0, 0], R[:, 1, 1], R[:, 2, 2]], axis=1)
    pick = np.argmax(diag, axis=1)
    q = np.empty((len(R), 4))  # (w, x, y, z)
    for case in range(4):
        k = pick == case
        if not k.any():
            continue
        r = R[k]
        if case == 0:
            s = 2.0 * np.sqrt(1.0 + trace[k])
            q[k] = np.column_stack([0.25 * s, (r[:, 2, 1] - r[:, 1, 2]) / s,
                                    (r[:, 0, 2] - r[:, 2, 0]) / s, (r[:, 1, 0] - r[:, 0, 1]) / s])
        else:
            i = case - 1
            j, m = (i + 1) % 3, (i + 2) % 3
            s = 2.0 * np.sqrt(np.maximum(1.0 + r[:, i, i] - r[:, j, j] - r[:, m, m], 1e-300))
            out = np.empty((len(r), 4))
            out[:, 0] = (r[:, m, j] - r[:, j, m]) / s
            out[:, 1 + i] = 0.25 * s
            out[:, 1 + j] = (r[:, j, i] + r[:, i, j]) / s
            out[:, 1 + m] = (r[:, m, i] + r[:, i, m]) / s
            q[k] = out
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    flips = np.concatenate([[1.0], np.sign(np.sum(q[1:] * q[:-1], axis=1) + 1e-300)])
    q *= np.cumprod(flips)[:, None]
    return np.column_stack([q[:, 1], q[:, 2], q[:, 3], q[:, 0]])
