"""Scene: distances to several obstacles, clearance, enlarging, scenario forms."""

from __future__ import annotations

import numpy as np
import pytest

from mmplan.errors import InputError, UnknownNameError
from mmplan.scene import Box, Cylinder, Scene, Sphere

# [PajakPajak], section 5 (docs/conventions.md): two cylinders and a sphere.
PAJAKPAJAK_OBSTACLES = [
    {
        "shape": "cylinder",
        "base_center": [0.15, 0.75, 0.0],
        "radius": 0.25,
        "height": 0.2,
        "influence": 0.35,
    },
    {"shape": "sphere", "center": [1.25, 0.70, 0.45], "radius": 0.15, "influence": 0.15},
    {
        "shape": "cylinder",
        "base_center": [1.25, 2.5, 0.0],
        "radius": 0.40,
        "height": 0.1,
        "influence": 0.35,
    },
]


def test_pajakpajak_scene_and_its_planner_models() -> None:
    scene = Scene.from_dicts(PAJAKPAJAK_OBSTACLES)
    assert len(scene) == 3
    assert scene.to_dicts() == PAJAKPAJAK_OBSTACLES
    models = [o.superellipsoid() for o in scene.enlarged(0.05)]
    # [PajakPajak] Table 1 (semi-axes before enlarging; the planner adds 0.05 m to each).
    expected = [
        ((0.15, 0.75, 0.10), (0.30, 0.30, 0.15), (0.1, 1.0)),
        ((1.25, 0.70, 0.45), (0.20, 0.20, 0.20), (1.0, 1.0)),
        ((1.25, 2.5, 0.05), (0.45, 0.45, 0.10), (0.1, 1.0)),
    ]
    for model, (center, axes, exps) in zip(models, expected, strict=True):
        assert model.center == pytest.approx(center)
        assert model.semi_axes == pytest.approx(axes)
        assert model.exponents == exps
    assert [m.influence for m in models] == [0.35, 0.15, 0.35]


def test_distances_and_clearance(rng: np.random.Generator) -> None:
    scene = Scene((Sphere((0, 0, 0), 1.0), Box((5, 0, 0), (2, 2, 2))))
    points = np.array([[2.0, 0, 0], [0, 0, 0], [7.0, 0, 0]])
    np.testing.assert_allclose(scene.distances(points), [[1, 2], [-1, 4], [6, 1]], atol=1e-14)
    assert scene.clearance(points) == pytest.approx(-1.0)
    assert scene.clearance(points[[0, 2]]) == pytest.approx(1.0)
    assert scene.clearance(points[[0, 2]], radii=[0.25, 0.5]) == pytest.approx(0.5)
    many = rng.uniform(-3, 8, (1000, 3))
    assert scene.clearance(many) == pytest.approx(scene.distances(many).min())
    assert scene.distances(many).shape == (1000, 2)
    assert Scene().clearance(many) == float("inf")
    assert Scene().distances(many).shape == (1000, 0)
    with pytest.raises(InputError) as info:
        scene.clearance(points, radii=[1.0])
    assert info.value.field == "radii"


def test_enlarged_and_iteration() -> None:
    scene = Scene((Sphere((0, 0, 0), 1.0), Cylinder((1, 1, 0), 0.5, 1.0)))
    big = scene.enlarged(0.1)
    assert list(big) == [Sphere((0, 0, 0), 1.1), Cylinder((1, 1, -0.1), 0.6, 1.2)]
    assert scene.enlarged(0.1) == big  # frozen, comparable, hashable
    assert hash(big) == hash(scene.enlarged(0.1))


def test_from_dicts_errors_name_the_item() -> None:
    bad = [PAJAKPAJAK_OBSTACLES[0], {"shape": "sphere", "center": [0, 0, 0], "radius": -1}]
    with pytest.raises(InputError) as info:
        Scene.from_dicts(bad)
    assert info.value.field == "[1].radius"
    with pytest.raises(UnknownNameError) as unknown:
        Scene.from_dicts([{"shape": "torus"}])
    assert unknown.value.field == "[0].shape"
    with pytest.raises(InputError) as not_obstacle:
        Scene(("sphere",))  # type: ignore[arg-type]
    assert not_obstacle.value.field == "obstacles[0]"
