"""Superellipsoid: implicit function, radial distance, symbolic forms and their gradients,
exact distance against an independent brute-force reference, [PajakPajak]'s obstacles; the
scenario shape against its model."""

from __future__ import annotations

import dataclasses
import math

import casadi as ca
import numpy as np
import pytest

from mmplan.scene import Cylinder, Obstacle, Sphere, Superellipsoid, SuperellipsoidModel

# (center, semi_axes, exponents, yaw): [PajakPajak]'s cylinder model and other convex cases.
CASES = [
    ((0.15, 0.75, 0.10), (0.25, 0.25, 0.10), (0.1, 1.0), 0.0),
    ((1.25, 0.70, 0.45), (0.15, 0.15, 0.15), (1.0, 1.0), 0.0),
    ((2.0, 1.0, 0.2), (0.2, 0.3, 0.1), (0.1, 0.1), 0.7),
    ((-1.0, 0.5, 0.3), (0.3, 0.2, 0.25), (0.6, 0.4), -1.2),
    ((0.0, 0.0, 0.0), (0.3, 0.2, 0.25), (1.5, 0.5), 0.3),
    ((0.0, 0.0, 0.0), (0.3, 0.2, 0.25), (2.0, 2.0), 0.0),
]
IDS = [f"e{c[2][0]}-{c[2][1]}" for c in CASES]
Smooth = Superellipsoid | SuperellipsoidModel  # the shape or its model: the same math


def _F(local: np.ndarray, a: np.ndarray, e1: float, e2: float) -> np.ndarray:
    """Barr's F written out again, independently of the package."""
    x, y, z = (np.abs(local[..., i]) / a[i] for i in range(3))
    return (x ** (2 / e2) + y ** (2 / e2)) ** (e2 / e1) + z ** (2 / e1)


def _local(s: Smooth, p: np.ndarray) -> np.ndarray:
    c, sn = math.cos(s.yaw), math.sin(s.yaw)
    d = p - np.asarray(s.center)
    return np.stack(
        [c * d[..., 0] + sn * d[..., 1], -sn * d[..., 0] + c * d[..., 1], d[..., 2]], -1
    )


def _surface(s: Smooth, directions: np.ndarray) -> np.ndarray:
    """Local surface points on the rays (scaled space) of ``directions`` (..., 3)."""
    a = np.asarray(s.semi_axes)
    local = directions * a
    return local / _F(local, a, *s.exponents)[..., None] ** (s.exponents[0] / 2)


def _reference(s: Smooth, points: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Unsigned distance by brute force: nearest of 1e5 surface samples, then 12 rounds of
    random local search around the best sample direction with a shrinking radius."""
    local = _local(s, points)
    dirs = rng.normal(size=(100_000, 3))
    surf = _surface(s, dirs)
    dist = np.linalg.norm(surf[None, :, :] - local[:, None, :], axis=2)
    best_i = dist.argmin(axis=1)
    best, best_d = dist[np.arange(len(points)), best_i], dirs[best_i]
    best_d /= np.linalg.norm(best_d, axis=1)[:, None]
    for k in range(12):
        trial = best_d[:, None, :] + 0.03 * 0.4**k * rng.normal(size=(len(points), 400, 3))
        dd = np.linalg.norm(_surface(s, trial) - local[:, None, :], axis=2)
        j = dd.argmin(axis=1)
        better = dd[np.arange(len(points)), j] < best
        best = np.where(better, dd[np.arange(len(points)), j], best)
        best_d = np.where(better[:, None], trial[np.arange(len(points)), j], best_d)
        best_d /= np.linalg.norm(best_d, axis=1)[:, None]
    return best


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_exact_distance_against_brute_force(case: tuple, rng: np.random.Generator) -> None:
    s = Superellipsoid(*case)
    a = np.asarray(s.semi_axes)
    local = rng.uniform(-1.3, 1.3, (80, 3)) * a
    c, sn = math.cos(s.yaw), math.sin(s.yaw)
    points = local @ np.array([[c, sn, 0], [-sn, c, 0], [0, 0, 1]]) + np.asarray(s.center)
    exact = s.distance(points)
    ref = _reference(s, points, rng)
    inside = _F(local, a, *s.exponents) < 1
    assert 5 < inside.sum() < 75
    np.testing.assert_array_equal(exact < 0, inside)
    assert np.all(ref >= np.abs(exact) - 1e-9)  # the reference is an upper bound
    np.testing.assert_allclose(np.abs(exact), ref, atol=1e-6, rtol=0)


def test_distance_of_sphere_model_is_closed_form(rng: np.random.Generator) -> None:
    sphere = Sphere((0.3, -0.2, 0.5), 0.4)
    points = rng.uniform(-1.0, 1.0, (2000, 3)) + np.asarray(sphere.center)
    np.testing.assert_allclose(
        sphere.superellipsoid().distance(points), sphere.distance(points), atol=1e-10
    )
    np.testing.assert_allclose(
        sphere.superellipsoid().radial_distance(points), sphere.distance(points), atol=1e-12
    )


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_implicit_and_radial_on_surface(case: tuple, rng: np.random.Generator) -> None:
    s = Superellipsoid(*case)
    local = _surface(s, rng.normal(size=(500, 3)))
    c, sn = math.cos(s.yaw), math.sin(s.yaw)
    world = local @ np.array([[c, sn, 0], [-sn, c, 0], [0, 0, 1]]) + np.asarray(s.center)
    np.testing.assert_allclose(s.implicit(world), 1.0, atol=1e-12)
    np.testing.assert_allclose(s.radial_distance(world), 0.0, atol=1e-12)
    np.testing.assert_allclose(s.distance(world), 0.0, atol=1e-9)
    # Along each ray, C is the signed distance travelled from the surface point.
    unit = (world - np.asarray(s.center)) / np.linalg.norm(local, axis=1)[:, None]
    for t in (-0.03, 0.05, 0.4):
        np.testing.assert_allclose(s.radial_distance(world + t * unit), t, atol=1e-12)


def _functions(s: Smooth) -> ca.Function:
    p = ca.SX.sym("p", 3)
    f, c = s.implicit_sym(p), s.radial_distance_sym(p)
    return ca.Function("f", [p], [f, c, ca.jacobian(f, p), ca.jacobian(c, p)])


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_symbolic_matches_numpy_and_finite_differences(
    case: tuple, rng: np.random.Generator
) -> None:
    s = Superellipsoid(*case)
    fun = _functions(s)
    a = np.asarray(s.semi_axes)
    points = np.asarray(s.center) + rng.uniform(-1.6, 1.6, (30, 3)) * a
    h = 1e-6
    for p in points:
        f, c, df, dc = (np.asarray(v, dtype=float).ravel() for v in fun(p))
        assert f == pytest.approx(s.implicit(p)[0], rel=1e-10)
        assert c == pytest.approx(s.radial_distance(p)[0], abs=1e-10)
        fd = np.array(
            [(s.radial_distance(p + h * e) - s.radial_distance(p - h * e))[0] for e in np.eye(3)]
        ) / (2 * h)
        np.testing.assert_allclose(dc, fd, atol=1e-6 * max(1.0, np.abs(fd).max()))
        fd_f = np.array([(s.implicit(p + h * e) - s.implicit(p - h * e))[0] for e in np.eye(3)]) / (
            2 * h
        )
        np.testing.assert_allclose(df, fd_f, rtol=1e-5, atol=1e-6 * np.abs(fd_f).max())


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_symbolic_derivatives_finite_on_axes_and_planes(case: tuple) -> None:
    s = Superellipsoid(*case)
    fun = _functions(s)
    c = np.asarray(s.center)
    for offset in ([0, 0, 0.5], [0, 0, -0.05], [0.4, 0, 0], [0, 0.3, 0.02], [0.1, 0.1, 0]):
        out = [np.asarray(v, dtype=float) for v in fun(c + np.asarray(offset))]
        assert all(np.isfinite(v).all() for v in out), offset


def test_enlarged_grows_semi_axes_and_distance_monotone(rng: np.random.Generator) -> None:
    s = Superellipsoid((0.15, 0.75, 0.1), (0.25, 0.25, 0.1), (0.1, 1.0), 0.2, influence=0.35)
    big = s.enlarged(0.05)
    assert big.semi_axes == pytest.approx((0.30, 0.30, 0.15))
    assert (big.center, big.exponents, big.yaw, big.influence) == (
        s.center,
        s.exponents,
        s.yaw,
        s.influence,
    )
    points = np.asarray(s.center) + rng.uniform(-0.6, 0.6, (300, 3))
    d, d_big, d_bigger = (o.distance(points) for o in (s, big, s.enlarged(0.1)))
    assert np.all(d_big < d) and np.all(d_bigger < d_big)
    assert np.all(big.radial_distance(points) < s.radial_distance(points))


def test_pajakpajak_cylinder_model_is_close_to_the_cylinder(rng: np.random.Generator) -> None:
    """[PajakPajak] Table 1: the cylinder r 0.25, h 0.2 on (0.15, 0.75, 0) as a superellipsoid.

    Measured Hausdorff gap: model surface -> cylinder 5.2 mm, cylinder surface -> model
    7.3 mm (both at the rounded rim of the top and bottom caps).
    """
    cyl = Cylinder((0.15, 0.75, 0.0), 0.25, 0.2)
    model = cyl.superellipsoid()
    model_surface = _surface(model, rng.normal(size=(20_000, 3))) + np.asarray(model.center)
    gap_model = np.abs(cyl.distance(model_surface)).max()
    n = 20_000
    phi, z = rng.uniform(0, 2 * math.pi, n), rng.uniform(0.0, 0.2, n)
    rad = 0.25 * np.sqrt(rng.uniform(0, 1, n))
    cap_z = np.where(rng.uniform(size=n) < 0.5, 0.0, 0.2)
    cyl_surface = np.vstack(
        [
            np.column_stack([0.25 * np.cos(phi), 0.25 * np.sin(phi), z]),
            np.column_stack([rad * np.cos(phi), rad * np.sin(phi), cap_z]),
        ]
    ) + np.array([0.15, 0.75, 0.0])
    gap_cyl = np.abs(model.distance(cyl_surface)).max()
    assert 0.003 < gap_model < 0.006
    assert 0.005 < gap_cyl < 0.008
    # Away from the rims (side band and cap centres) the model is within 0.5 mm.
    side = np.abs(cyl_surface[:n, 2] - 0.1) < 0.05
    centre = rad < 0.15
    assert np.abs(model.distance(cyl_surface[:n][side])).max() < 5e-4
    assert np.abs(model.distance(cyl_surface[n:][centre])).max() < 5e-4


@pytest.mark.parametrize("case", CASES[:4], ids=IDS[:4])
def test_approximate_seeds_change_nothing(case: tuple, rng: np.random.Generator) -> None:
    """Far points (approximate k-d tree seeds, certified or redone) equal exact-seed runs."""
    from mmplan.scene import _gauge

    s = Superellipsoid(*case)
    direction = rng.normal(size=(300, 3))
    local = direction / np.linalg.norm(direction, axis=1)[:, None] * rng.uniform(0, 30, (300, 1))
    local[:4] = [[0, 0, 4.0], [0, 0, -25.0], [0.01, 0, 12.0], [7.0, 0.0, 0.0]]  # facing caps
    e1, e2 = s.exponents
    fast = _gauge.signed_distance(local, s.semi_axes, e1, e2)
    exact = _gauge.signed_distance(local, s.semi_axes, e1, e2, approximate_seeds=False)
    np.testing.assert_allclose(fast, exact, atol=1e-12, rtol=0)
    # Straight above the centre the nearest point is the top pole: closed form.
    np.testing.assert_allclose(fast[:2], [4.0 - s.semi_axes[2], 25.0 - s.semi_axes[2]], atol=1e-9)


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_shape_delegates_to_its_model_bit_for_bit(case: tuple, rng: np.random.Generator) -> None:
    """The scenario shape is an obstacle with the model's fields; the model is no obstacle."""
    s = Superellipsoid(*case, influence=0.2)
    m = s.superellipsoid()
    assert type(m) is SuperellipsoidModel and not isinstance(m, Obstacle)
    assert dataclasses.astuple(m) == dataclasses.astuple(s)
    assert s.enlarged(0.05).superellipsoid() == m.enlarged(0.05)
    points = np.asarray(s.center) + rng.uniform(-1.5, 1.5, (200, 3)) * np.asarray(s.semi_axes)
    for name in ("local", "implicit", "gauge", "radial_distance", "distance"):
        np.testing.assert_array_equal(getattr(s, name)(points), getattr(m, name)(points))
    p = ca.SX.sym("p", 3)
    for name in ("local_sym", "implicit_sym", "radial_distance_sym", "signed_distance_sym"):
        ours, theirs = (ca.Function("f", [p], [getattr(o, name)(p)]) for o in (s, m))
        for q in points[:20]:
            np.testing.assert_array_equal(np.asarray(ours(q)), np.asarray(theirs(q)))
