"""Sphere, cylinder, box: closed forms, brute-force surface sampling, enlarging, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mmplan.errors import InputError, UnknownNameError
from mmplan.scene import Box, Cylinder, Obstacle, Sphere, SuperellipsoidModel, obstacle_from_dict

SPACING = 0.002  # brute-force surface sample spacing [m]


def _grid(lo: float, hi: float) -> np.ndarray:
    return np.linspace(lo, hi, max(2, math.ceil((hi - lo) / SPACING) + 1))


def _sphere_surface(s: Sphere) -> np.ndarray:
    n = math.ceil(math.pi * s.radius / SPACING)
    theta, phi = np.meshgrid(np.linspace(0, math.pi, n), np.linspace(0, 2 * math.pi, 2 * n))
    unit = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])
    return unit.reshape(3, -1).T * s.radius + np.asarray(s.center)


def _cylinder_surface(c: Cylinder) -> np.ndarray:
    x0, y0, z0 = c.base_center
    phi = np.linspace(0, 2 * math.pi, math.ceil(2 * math.pi * c.radius / SPACING))
    pp, zz = np.meshgrid(phi, _grid(0.0, c.height))
    side = np.stack([c.radius * np.cos(pp), c.radius * np.sin(pp), zz], axis=-1).reshape(-1, 3)
    xs = _grid(-c.radius, c.radius)
    gx, gy = (m.ravel() for m in np.meshgrid(xs, xs))
    keep = gx**2 + gy**2 <= c.radius**2
    disc = np.stack([gx[keep], gy[keep]], axis=1)
    caps = [np.column_stack([disc, np.full(len(disc), z)]) for z in (0.0, c.height)]
    return np.vstack([side, *caps]) + np.array([x0, y0, z0])


def _box_surface(b: Box) -> np.ndarray:
    h = b.half_extents
    faces = []
    for axis in range(3):
        i, j = (k for k in range(3) if k != axis)
        gi, gj = (m.ravel() for m in np.meshgrid(_grid(-h[i], h[i]), _grid(-h[j], h[j])))
        for sign in (-1.0, 1.0):
            f = np.zeros((gi.size, 3))
            f[:, i], f[:, j], f[:, axis] = gi, gj, sign * h[axis]
            faces.append(f)
    local = np.vstack(faces)
    c, s = math.cos(b.yaw), math.sin(b.yaw)
    rot = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    return local @ rot.T + np.asarray(b.center)


def _brute(surface: np.ndarray, points: np.ndarray) -> np.ndarray:
    from scipy.spatial import cKDTree

    return np.asarray(cKDTree(surface).query(points)[0])


SHAPES = [
    (Sphere((1.25, 0.70, 0.45), 0.15), _sphere_surface),
    (Cylinder((0.15, 0.75, 0.0), 0.25, 0.2), _cylinder_surface),
    (Cylinder((1.25, 2.5, 0.0), 0.40, 0.10), _cylinder_surface),
    (Box((2.0, 1.0, 0.2), (0.4, 0.3, 0.2), yaw=0.6), _box_surface),
]


@pytest.mark.parametrize(("obstacle", "surface"), SHAPES, ids=lambda x: getattr(x, "shape", ""))
def test_distance_matches_brute_force_sampling(
    obstacle: Obstacle, surface: object, rng: np.random.Generator
) -> None:
    model = obstacle.superellipsoid()
    center, extent = np.asarray(model.center), np.asarray(model.semi_axes)
    points = center + rng.uniform(-1.6, 1.6, (400, 3)) * (extent + 0.05)
    exact = obstacle.distance(points)
    brute = _brute(surface(obstacle), points)  # type: ignore[operator]
    gap = brute - np.abs(exact)  # brute force is an upper bound of the true distance
    assert gap.min() > -1e-12
    assert gap.max() < SPACING
    # Sign: against an inside test written from each shape's definition.
    inside = _inside(obstacle, points)
    assert 20 < inside.sum() < 380
    np.testing.assert_array_equal(exact < 0, inside)


def _inside(o: Obstacle, p: np.ndarray) -> np.ndarray:
    if isinstance(o, Sphere):
        return np.linalg.norm(p - np.asarray(o.center), axis=1) < o.radius
    if isinstance(o, Cylinder):
        d = p - np.asarray(o.base_center)
        return (np.hypot(d[:, 0], d[:, 1]) < o.radius) & (d[:, 2] > 0) & (d[:, 2] < o.height)
    assert isinstance(o, Box)
    c, s = math.cos(o.yaw), math.sin(o.yaw)
    d = p - np.asarray(o.center)
    local = np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1], d[:, 2]], 1)
    return np.all(np.abs(local) < np.asarray(o.half_extents), axis=1)


def test_sphere_closed_form() -> None:
    s = Sphere((1.0, 2.0, 3.0), 0.5)
    pts = np.array([[1.0, 2.0, 3.0], [1.0, 2.0, 4.0], [4.0, 6.0, 3.0], [1.3, 2.4, 3.0]])
    np.testing.assert_allclose(s.distance(pts), [-0.5, 0.5, 4.5, 0.0], atol=1e-15)


def test_cylinder_axis_and_rim() -> None:
    c = Cylinder((1.0, -1.0, 0.5), radius=0.3, height=0.4)
    axis = np.array([[1.0, -1.0, z] for z in (0.0, 0.5, 0.6, 0.7, 0.9, 1.5)])
    # On the axis: below the base, at the base, inside (nearest: cap at 0.1 vs side 0.3), ...
    np.testing.assert_allclose(c.distance(axis), [0.5, 0.0, -0.1, -0.2, 0.0, 0.6], atol=1e-15)
    rim = np.array([[1.0 + 0.3 + 0.3, -1.0, 0.9 + 0.4]])  # diagonal off the top rim
    np.testing.assert_allclose(c.distance(rim), [0.5], atol=1e-15)
    side = np.array([[1.0, -1.0 + 0.5, 0.7]])
    np.testing.assert_allclose(c.distance(side), [0.2], atol=1e-15)


def test_box_faces_edges_and_yaw() -> None:
    b = Box((0.0, 0.0, 1.0), (2.0, 1.0, 0.5), yaw=math.pi / 2)  # local x' along world y
    pts = np.array(
        [
            [0.0, 1.5, 1.0],  # beyond the +x' face (half 1.0)
            [0.8, 0.0, 1.0],  # beyond the +y' face (world -x side is -y'): half 0.5
            [0.0, 0.0, 1.0],  # centre: nearest face z (half 0.25)
            [0.0, 0.0, 1.5],  # above the top face
            [-0.5 - 0.3, 1.0 + 0.4, 1.0],  # off an edge: (0.3, 0.4) -> 0.5
        ]
    )
    np.testing.assert_allclose(b.distance(pts), [0.5, 0.3, -0.25, 0.25, 0.5], atol=1e-15)


def test_enlarged_sphere_is_exact_and_others_monotone(rng: np.random.Generator) -> None:
    pts = rng.uniform(-1.0, 1.0, (500, 3)) + np.array([0.5, 0.5, 0.3])
    eps = 0.05
    s = Sphere((0.5, 0.5, 0.3), 0.2)
    np.testing.assert_allclose(s.enlarged(eps).distance(pts), s.distance(pts) - eps, atol=1e-14)
    for o, stretch in ((Cylinder((0.5, 0.5, 0.1), 0.2, 0.3), 2**0.5), (SHAPES[3][0], 3**0.5)):
        d, d_big = o.distance(pts), o.enlarged(eps).distance(pts)
        # The grown shape contains the eps-offset of the original and is inside its box hull.
        assert np.all(d_big <= d - eps + 1e-12)
        assert np.all(d_big >= d - stretch * eps - 1e-12)
    assert Cylinder((0, 0, 0), 0.2, 0.3).enlarged(eps) == Cylinder((0, 0, -eps), 0.25, 0.4)


def test_superellipsoid_models() -> None:
    s = Sphere((1.25, 0.70, 0.45), 0.15, influence=0.15).superellipsoid()
    assert s == SuperellipsoidModel((1.25, 0.70, 0.45), (0.15, 0.15, 0.15), (1.0, 1.0), 0.0, 0.15)
    c = Cylinder((1.25, 2.5, 0.0), 0.4, 0.1, influence=0.35).superellipsoid()
    assert c.center == pytest.approx((1.25, 2.5, 0.05))
    assert c.semi_axes == pytest.approx((0.4, 0.4, 0.05))
    assert (c.exponents, c.influence) == ((0.1, 1.0), 0.35)
    b = Box((2.0, 1.0, 0.2), (0.4, 0.6, 0.2), yaw=0.3).superellipsoid()
    assert (b.semi_axes, b.exponents, b.yaw) == ((0.2, 0.3, 0.1), (0.1, 0.1), 0.3)


@pytest.mark.parametrize(
    "data",
    [
        {"shape": "sphere", "center": [1, 2, 3], "radius": 0.5, "influence": 0.2},
        {"shape": "cylinder", "base_center": [1, 2, 0], "radius": 0.4, "height": 0.1},
        {"shape": "box", "center": [2, 1, 0.2], "size": [0.4, 0.4, 0.4], "yaw": 0.0},
        {
            "shape": "superellipsoid",
            "center": [0.15, 0.75, 0.1],
            "semi_axes": [0.25, 0.25, 0.1],
            "exponents": [0.1, 1.0],
            "yaw": 0.0,
        },
    ],
)
def test_dict_round_trip(data: dict[str, object]) -> None:
    o = obstacle_from_dict(data)
    assert o.shape == data["shape"]
    assert o.to_dict() == data
    assert obstacle_from_dict(o.to_dict()) == o


@pytest.mark.parametrize(
    ("data", "field"),
    [
        ({"shape": "sphere", "center": [0, 0, 0], "radius": -0.1}, "radius"),
        ({"shape": "sphere", "center": [0, float("nan"), 0], "radius": 1}, "center[1]"),
        ({"shape": "sphere", "center": [0, 0], "radius": 1}, "center"),
        ({"shape": "cylinder", "base_center": [0, 0, 0], "radius": 1, "height": 0}, "height"),
        ({"shape": "box", "center": [0, 0, 0], "size": [1, -1, 1]}, "size[1]"),
        ({"shape": "box", "center": [0, 0, 0], "size": [1, 1, 1], "yaw": "a"}, "yaw"),
        (
            {
                "shape": "superellipsoid",
                "center": [0, 0, 0],
                "semi_axes": [1, 1, 1],
                "exponents": [0.0, 1.0],
            },
            "exponents[0]",
        ),
        (
            {
                "shape": "superellipsoid",
                "center": [0, 0, 0],
                "semi_axes": [1, 1, 1],
                "exponents": [1.0, 2.5],
            },
            "exponents[1]",
        ),
        ({"shape": "sphere", "center": [0, 0, 0], "radius": 1, "influence": 0}, "influence"),
        ({"shape": "sphere", "center": [0, 0, 0], "radius": 1, "colour": 1}, "colour"),
        ({"shape": "sphere", "center": [0, 0, 0]}, "radius"),
        ({"center": [0, 0, 0]}, "shape"),
    ],
)
def test_bad_input_names_the_field(data: dict[str, object], field: str) -> None:
    with pytest.raises(InputError) as info:
        obstacle_from_dict(data)
    assert info.value.field == field


def test_unknown_shape_lists_choices() -> None:
    with pytest.raises(UnknownNameError, match="box, cylinder, sphere, superellipsoid"):
        obstacle_from_dict({"shape": "cone"})
    with pytest.raises(InputError) as info:
        Sphere((0, 0, 0), 1).enlarged(float("inf"))
    assert info.value.field == "eps"
