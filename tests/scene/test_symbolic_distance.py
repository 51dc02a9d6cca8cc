"""Symbolic (CasADi) distances of every shape, as the tracking planners use them."""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np
import pytest

from mmplan.scene import Obstacle, Superellipsoid, obstacle_from_dict, shape_names
from mmplan.scene.obstacle import excess_distance_sym, norm_sym

EXACT: list[dict[str, Any]] = [
    {"shape": "sphere", "center": [0.3, -0.2, 0.5], "radius": 0.25},
    {"shape": "cylinder", "base_center": [2.0, 0.05, 0.0], "radius": 0.15, "height": 0.5},
    {"shape": "cylinder", "base_center": [0.35, 0.0, 0.0], "radius": 0.01, "height": 0.4},
    {"shape": "box", "center": [0.1, 0.2, 0.3], "size": [0.4, 0.3, 0.2], "yaw": 0.7},
    {"shape": "box", "center": [-1.0, 0.5, 0.1], "size": [0.2, 0.6, 0.4]},
]
SMOOTH: list[dict[str, Any]] = [
    {
        "shape": "superellipsoid",
        "center": [0.0, 2.0, 0.1],
        "semi_axes": [0.3, 0.3, 0.1],
        "exponents": [0.1, 1.0],
    },
    {
        "shape": "superellipsoid",
        "center": [0.2, -0.4, 0.3],
        "semi_axes": [0.5, 0.2, 0.3],
        "exponents": [0.6, 0.4],
        "yaw": -0.3,
    },
]


def _ids(data: dict[str, Any]) -> str:
    return str(data["shape"])


def _center(obstacle: Obstacle) -> np.ndarray:
    return np.asarray(obstacle.superellipsoid().center, dtype=float)


def _function(obstacle: Obstacle, horizontal: bool = False) -> ca.Function:
    p = ca.SX.sym("p", 3)
    d = obstacle.horizontal_distance_sym(p) if horizontal else obstacle.signed_distance_sym(p)
    return ca.Function("d", [p], [d, ca.gradient(d, p)])


def _evaluate(f: ca.Function, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    values, grads = f.map(len(points))(points.T)
    return np.asarray(values).reshape(-1), np.asarray(grads).T


def test_every_registered_shape_has_a_symbolic_distance() -> None:
    covered = {d["shape"] for d in EXACT + SMOOTH}
    assert covered == set(shape_names())
    for data in EXACT + SMOOTH:
        d = obstacle_from_dict(data).signed_distance_sym(ca.SX.sym("p", 3))
        assert d.shape == (1, 1)


@pytest.mark.parametrize("data", EXACT, ids=_ids)
def test_closed_forms_equal_the_exact_distance(rng: np.random.Generator, data: dict) -> None:
    obstacle = obstacle_from_dict(data)
    points = _center(obstacle) + rng.uniform(-0.8, 0.8, (400, 3))
    values, grads = _evaluate(_function(obstacle), points)
    np.testing.assert_allclose(values, obstacle.distance(points), atol=1e-8)
    # A signed distance has a unit gradient almost everywhere (the AD derivative of the
    # closed form, compared with central differences of the checker's distance).
    np.testing.assert_allclose(np.linalg.norm(grads, axis=1), 1.0, atol=1e-6)
    h = 1e-6
    fd = np.column_stack(
        [
            (obstacle.distance(points + h * e) - obstacle.distance(points - h * e)) / (2 * h)
            for e in np.eye(3)
        ]
    )
    smooth = np.linalg.norm(fd, axis=1) > 1 - 1e-4  # away from the medial axis and edges
    assert smooth.mean() > 0.9
    np.testing.assert_allclose(grads[smooth], fd[smooth], atol=1e-4)


@pytest.mark.parametrize("data", SMOOTH, ids=_ids)
def test_superellipsoid_uses_its_radial_distance(rng: np.random.Generator, data: dict) -> None:
    obstacle = obstacle_from_dict(data)
    assert isinstance(obstacle, Superellipsoid)
    points = _center(obstacle) + rng.uniform(-0.8, 0.8, (400, 3))
    values, grads = _evaluate(_function(obstacle), points)
    np.testing.assert_allclose(values, obstacle.radial_distance(points), atol=1e-9)
    assert np.isfinite(grads).all()
    # Same sign as the exact distance and never smaller in magnitude.
    exact = obstacle.distance(points)
    assert (np.sign(values) == np.sign(exact)).all()
    assert (np.abs(values) >= np.abs(exact) - 1e-9).all()


@pytest.mark.parametrize("data", EXACT + SMOOTH, ids=_ids)
def test_horizontal_distance_measures_at_the_middle_height(
    rng: np.random.Generator, data: dict
) -> None:
    obstacle = obstacle_from_dict(data)
    c = _center(obstacle)
    points = c + rng.uniform(-0.8, 0.8, (200, 3))
    at_middle = points.copy()
    at_middle[:, 2] = c[2]
    horizontal, grads = _evaluate(_function(obstacle, horizontal=True), points)
    full, _ = _evaluate(_function(obstacle), at_middle)
    np.testing.assert_array_equal(horizontal, full)
    np.testing.assert_array_equal(grads[:, 2], 0.0)  # height does not matter


def test_helpers_finite_gradient_at_zero() -> None:
    v = ca.SX.sym("v", 3)
    f = ca.Function("n", [v], [norm_sym(v), ca.gradient(norm_sym(v), v)])
    value, grad = f(np.zeros(3))
    assert float(value) == pytest.approx(1e-9)
    assert np.isfinite(np.asarray(grad)).all()
    e = ca.SX.sym("e", 2)
    g = ca.Function("d", [e], [excess_distance_sym([e[0], e[1]])])
    assert float(g([0.3, 0.4])) == pytest.approx(0.5)  # outside a corner
    assert float(g([-0.3, -0.1])) == pytest.approx(-0.1)  # inside: the larger excess
    assert float(g([0.2, -0.1])) == pytest.approx(0.2)  # outside a face
