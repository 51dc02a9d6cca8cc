"""How a URDF robot looks: its links' ``<visual>`` geometry, meshes included.

:func:`urdf_body_visuals` turns the visual elements of
:func:`mmplan.robot.urdf.visuals.visual_elements` (each already posed in the tree body that
carries it, held links merged in place) into :class:`~mmplan.report.visuals.Visual` pieces:

* boxes, cylinders and spheres as they are;
* meshes (STL, OBJ, DAE; :mod:`mmplan.report.meshes`) as indexed triangles in the body
  frame with the URDF scale applied, welded and split at creases; a DAE's parts keep their
  own colours where the URDF gives none;
* colours from the URDF materials (alpha as opacity), else the file's, else grey.

The page embeds every triangle, so the robot's triangles are bounded: above
:data:`MAX_TRIANGLES` every mesh is decimated by vertex clustering with the smallest cell
(:data:`CELLS`) that brings the total under it. A mesh file that is missing or cannot be read
is left out and named in :attr:`UrdfLooks.skipped`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mmplan.arrays import Array
from mmplan.report import meshes
from mmplan.report.visual import Visual, VisualKind

if TYPE_CHECKING:
    from mmplan.robot.urdf.robot import UrdfRobot

#: Triangles of all meshes of one robot above which meshes are decimated.
MAX_TRIANGLES = 150_000
#: Vertex-clustering cells tried in turn [m].
CELLS = (0.001, 0.002, 0.003, 0.005, 0.008, 0.012, 0.02)
#: Colour of a mesh without any.
DEFAULT_COLOR = "#a9b0b7"

_KINDS = {"box": VisualKind.BOX, "cylinder": VisualKind.CYLINDER, "sphere": VisualKind.SPHERE}


@dataclass
class UrdfLooks:
    """Visual pieces by body and what could not be drawn.

    Attributes:
        bodies: Pieces per tree body.
        skipped: ``"link: file (reason)"`` of each mesh left out.
        triangles: Triangles of all meshes as drawn.
        cell: Vertex-clustering cell used [m], 0 where nothing was decimated.
    """

    bodies: dict[str, list[Visual]] = field(default_factory=dict)
    skipped: list[str] = field(default_factory=list)
    triangles: int = 0
    cell: float = 0.0


def hex_color(rgba: tuple[float, ...]) -> str:
    """``#rrggbb`` of an RGBA (0..1) colour."""
    return "#" + "".join(f"{round(255 * float(np.clip(c, 0.0, 1.0))):02x}" for c in rgba[:3])


#: A mesh's shape: its file, the URDF scale and the part of the file.
_Key = tuple[Path, tuple[float, ...], int]


@dataclass
class _Mesh:
    body: str
    name: str
    pose: Array
    key: _Key
    color: str
    opacity: float


class _Shapes:
    """Each distinct mesh shape (file, scale, part) read and processed once: files reused by
    several links (wheels, casters, fingers) cost one read and one crease split."""

    def __init__(self) -> None:
        self.files: dict[Path, list[meshes.MeshPart]] = {}
        self.shapes: dict[_Key, tuple[Array, np.ndarray]] = {}

    def parts(self, path: Path) -> list[meshes.MeshPart]:
        if path not in self.files:
            self.files[path] = meshes.read_mesh(path)
        return self.files[path]

    def add(self, key: _Key, part: meshes.MeshPart) -> bool:
        """Weld the part at its scale; False when nothing of it is left."""
        if key not in self.shapes:
            scale = np.asarray(key[1])
            vertices, faces = meshes.weld(part.vertices * scale, part.faces)
            if np.prod(scale) < 0:
                faces = faces[:, ::-1]  # a mirror turns the faces inside out
            self.shapes[key] = (vertices, faces)
        return len(self.shapes[key][1]) > 0


def urdf_body_visuals(robot: UrdfRobot) -> UrdfLooks:
    """The visual pieces of a :class:`~mmplan.robot.urdf.UrdfRobot` by body (see the module
    docstring); empty for a robot given as URDF text."""
    from mmplan.robot.urdf.visuals import visual_elements

    looks = UrdfLooks()
    shapes = _Shapes()
    pending: list[_Mesh] = []
    for body, elements in visual_elements(robot).items():
        pieces = looks.bodies.setdefault(body, [])
        taken: set[str] = set()
        for element in elements:
            rgba = element.rgba
            if element.kind in _KINDS:
                pieces.append(Visual(_unique(element.link, taken), _KINDS[element.kind],
                                     element.size, element.pose,
                                     hex_color(rgba) if rgba else DEFAULT_COLOR,
                                     float(rgba[3]) if rgba else 1.0))
                continue
            assert element.mesh is not None
            try:
                parts = shapes.parts(element.mesh)
            except (OSError, meshes.MeshError) as exc:
                reason = "missing" if isinstance(exc, FileNotFoundError) else str(exc)
                looks.skipped.append(f"{element.link}: {element.filename} ({reason})")
                continue
            for k, part in enumerate(parts):
                key = (element.mesh, tuple(float(v) for v in element.size), k)
                if not shapes.add(key, part):
                    continue
                color = rgba or part.rgba
                pending.append(_Mesh(body, _unique(element.link, taken), element.pose, key,
                                     hex_color(color) if color else DEFAULT_COLOR,
                                     float(color[3]) if color else 1.0))
    _decimate(shapes, pending, looks)
    split = {key: meshes.split_creases(*shapes.shapes[key]) for key in {m.key for m in pending}}
    for mesh in pending:
        vertices, faces = split[mesh.key]
        looks.bodies[mesh.body].append(
            Visual(mesh.name, VisualKind.MESH, (1.0, 1.0, 1.0), mesh.pose, mesh.color,
                   mesh.opacity, vertices=vertices, faces=faces))
        looks.triangles += len(faces)
    looks.bodies = {b: v for b, v in looks.bodies.items() if v}
    return looks


def _unique(link: str, taken: set[str]) -> str:
    """``link``, else ``link_2``, ``link_3``, ... whichever is free (then taken)."""
    name, k = link, 2
    while name in taken:
        name, k = f"{link}_{k}", k + 1
    taken.add(name)
    return name


def _decimate(shapes: _Shapes, pending: list[_Mesh], looks: UrdfLooks) -> None:
    """Cluster every shape with the smallest cell of :data:`CELLS` that brings the drawn
    total under :data:`MAX_TRIANGLES` (the largest when none does)."""
    uses: dict[_Key, int] = {}
    for mesh in pending:
        uses[mesh.key] = uses.get(mesh.key, 0) + 1

    def total(faces_of: dict[_Key, int]) -> int:
        return sum(faces_of[key] * n for key, n in uses.items())

    if total({k: len(shapes.shapes[k][1]) for k in uses}) <= MAX_TRIANGLES:
        return
    results: dict[_Key, tuple[Array, np.ndarray]] = {}
    for cell in CELLS:
        results = {k: meshes.cluster(*shapes.shapes[k], cell) for k in uses}
        if total({k: len(r[1]) for k, r in results.items()}) <= MAX_TRIANGLES:
            break
    looks.cell = cell
    shapes.shapes.update(results)
