"""One visual piece of a robot body (:class:`Visual`), its kinds and the drawing colours.

The vocabulary shared by the builders of a robot's looks (:mod:`mmplan.report.visuals` for
built-in robots, :mod:`mmplan.report.urdf_visuals` for URDF robots) and the 3D view.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from mmplan.arrays import Array

PLATFORM_COLOR = "#607d8b"
WHEEL_COLOR = "#263238"
SPOKE_COLOR = "#cfd8dc"
LINK_COLOR = "#f28e2b"
JOINT_COLOR = "#37474f"
TOOL_COLOR = "#d62728"
COLLISION_COLOR = "#5f6368"  # the collision model (drawn by the 3D view, not a visual)


class VisualKind(Enum):
    """Primitive kinds of :class:`Visual`."""

    BOX = "box"
    CYLINDER = "cylinder"
    SPHERE = "sphere"
    MESH = "mesh"


@dataclass(frozen=True)
class Visual:
    """One visual piece of a body, posed in the body frame.

    Attributes:
        name: Unique within the body (a scene path element).
        kind: Primitive kind.
        size: BOX: edge lengths (x, y, z) [m]; CYLINDER: (radius, length) [m] along the
            piece's z axis, centred; SPHERE: (radius,) [m]; MESH: scale factors (x, y, z).
        pose: T_body_piece (4, 4).
        color: ``#rrggbb``.
        opacity: 1 opaque, < 1 translucent.
        vertices, faces: MESH given as triangles: (V, 3) [m] and (F, 3) vertex indices.
        mesh_data, mesh_format: MESH given as a file's contents (``stl`` as bytes, ``obj`` and
            ``dae`` as text) and its format.
    """

    name: str
    kind: VisualKind
    size: tuple[float, ...]
    pose: Array = field(default_factory=lambda: np.eye(4))
    color: str = LINK_COLOR
    opacity: float = 1.0
    vertices: Array | None = None
    faces: np.ndarray | None = None
    mesh_data: bytes | str | None = None
    mesh_format: str = ""
