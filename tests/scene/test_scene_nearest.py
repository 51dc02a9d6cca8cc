"""Scene.nearest: the smallest gap over points and obstacles without the dense matrix."""

from __future__ import annotations

import numpy as np

from mmplan.scene.box import Box
from mmplan.scene.cylinder import Cylinder
from mmplan.scene.scene import Scene
from mmplan.scene.sphere import Sphere


def test_nearest_equals_the_dense_minimum_on_random_scenes() -> None:
    """Against the (P, n_obs) matrix of Scene.distances: the same gap, point and obstacle
    (first in (point, obstacle) order), for scenes of 1-300 obstacles around and among a point
    cloud, with and without radii (a cull that skipped obstacles within 0.5 m of the bound
    passed the first version of this test: most scenes now crowd the points)."""
    rng = np.random.default_rng(3)
    for trial in range(40):
        count = int(rng.integers(1, 300))
        spread = 6.0 if trial % 4 == 0 else 1.5  # mostly crowded: the cull's bound decides
        obstacles = []
        for _ in range(count):
            c = rng.uniform(-spread, spread, 3)
            kind = rng.integers(3)
            if kind == 0:
                obstacles.append(Sphere(tuple(c), float(rng.uniform(0.05, 0.5))))
            elif kind == 1:
                obstacles.append(Cylinder(tuple(c), float(rng.uniform(0.05, 0.5)),
                                          float(rng.uniform(0.1, 1.0))))  # fmt: skip
            else:
                obstacles.append(Box(tuple(c), tuple(rng.uniform(0.1, 1.0, 3)),
                                     yaw=float(rng.uniform(-3, 3))))  # fmt: skip
        scene = Scene(tuple(obstacles))
        size = 0.7 if trial % 2 else 0.05  # a compact cloud: a tight bound, the order matters
        points = rng.normal(0.0, size, (int(rng.integers(1, 400)), 3))
        radii = rng.uniform(0.0, 0.1, len(points)) if trial % 2 else None
        dense = scene.distances(points)
        if radii is not None:
            dense = dense - radii[:, None]
        row, o = np.unravel_index(int(np.argmin(dense)), dense.shape)
        assert scene.nearest(points, radii) == (float(dense[row, o]), int(row), int(o))
        assert scene.clearance(points, radii) == float(dense.min())
    assert Scene(()).nearest(np.zeros((2, 3))) == (float("inf"), -1, -1)


def test_a_point_that_is_not_finite_gives_nan_where_it_is() -> None:
    scene = Scene((Sphere((1.0, 0.0, 0.0), 0.2),))
    points = np.array([[0.0, 0.0, 0.0], [np.nan, 0.0, 0.0], [0.5, 0.0, 0.0]])
    gap, point, obstacle = scene.nearest(points)
    assert np.isnan(gap) and (point, obstacle) == (1, 0)
    assert np.isnan(scene.clearance(points))
