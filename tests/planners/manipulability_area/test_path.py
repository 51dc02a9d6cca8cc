"""Path searches in a voxelized LMA (manipulability_area/path.py) against brute-force references."""

from __future__ import annotations

import itertools

import numpy as np

from mmplan.planners.manipulability_area import path as lma_path


def brute_force_straight(masks: np.ndarray) -> tuple[float, set[tuple[int, int, int, int]]]:
    """[Nagatani] s.4.1 round robin, literally: every (start, end) pair, every layer (rounded)."""
    L = masks.shape[0]
    best, pairs = np.inf, set[tuple[int, int, int, int]]()
    for a in np.argwhere(masks[0]):
        for b in np.argwhere(masks[-1]):
            ok = True
            for k in range(L):
                c = np.floor(a + k / (L - 1) * (b - a) + 0.5).astype(int)
                if not masks[k, c[0], c[1]]:
                    ok = False
                    break
            if ok:
                length = float(np.hypot(*(b - a)))
                if length < best - 1e-12:
                    best, pairs = length, set()
                if abs(length - best) < 1e-12:
                    pairs.add((int(a[0]), int(a[1]), int(b[0]), int(b[1])))
    return best, pairs


def test_straight_search_equals_round_robin(rng: np.random.Generator) -> None:
    for trial in range(12):
        L, nx, ny = 5, 9, 11
        density = 0.55 + 0.04 * trial
        masks = rng.random((L, nx, ny)) < density
        best, pairs = brute_force_straight(masks)
        first = next(iter(lma_path.straight_candidates(masks)), None)
        if not np.isfinite(best):
            assert first is None
            continue
        assert first is not None
        assert abs(first.length_cells - best) < 1e-12
        found = {(*map(int, a), *map(int, b)) for a, b in zip(first.starts, first.ends,
                                                               strict=True)}
        assert found == pairs


def test_groups_come_in_increasing_length(rng: np.random.Generator) -> None:
    masks = rng.random((4, 10, 10)) < 0.8
    lengths = [g.length_cells for g in itertools.islice(lma_path.straight_candidates(masks), 20)]
    assert len(lengths) >= 2
    assert all(b > a for a, b in itertools.pairwise(lengths))


def test_vertical_segment_is_first_when_it_exists() -> None:
    masks = np.zeros((6, 8, 8), dtype=bool)
    masks[:, 3, 4] = True
    masks[0, 0, 0] = masks[-1, 1, 1] = True
    first = next(iter(lma_path.straight_candidates(masks)))
    assert first.length_cells == 0.0
    assert first.starts.tolist() == [[3, 4]]


def bent_tube(L: int = 11, n: int = 20) -> np.ndarray:
    """A tube whose axis goes from (4, 4) out to (4, 14) at the middle layer and back."""
    masks = np.zeros((L, n, n), dtype=bool)
    for k in range(L):
        cj = 4 + round(10 * (1 - abs(2 * k / (L - 1) - 1)))
        masks[k, 3:6, cj - 1: cj + 2] = True
    return masks


def test_bent_tube_has_no_straight_segment_but_a_subgoal_path() -> None:
    masks = bent_tube()
    assert next(iter(lma_path.straight_candidates(masks)), None) is None
    assert brute_force_straight(masks)[0] == np.inf
    path, bad = lma_path.layered_shortest_path(masks, max_step=2)
    assert path is not None and bad == -1
    assert masks[np.arange(len(path)), path[:, 0], path[:, 1]].all()
    steps = np.hypot(*np.diff(path, axis=0).T)
    assert steps.max() <= 2.0 + 1e-12
    # the tube's axis moves 10 cells out and back: at least 2 * (10 - 2) cells of motion
    assert steps.sum() >= 16.0 - 1e-9

    def inside(i: int, pts: np.ndarray) -> bool:
        cells = np.floor(pts + 0.5).astype(int)
        return bool(masks[np.arange(i, i + len(pts)), cells[:, 0], cells[:, 1]].all())

    keep = lma_path.shortcut(path, inside)
    assert keep[0] == 0 and keep[-1] == len(path) - 1
    assert 3 <= len(keep) < len(path)  # one bend at least, fewer pieces than layers


def test_layered_shortest_path_equals_bellman_ford(rng: np.random.Generator) -> None:
    """DP layer by layer = plain relaxation over all cell pairs (small random LMAs)."""
    for _ in range(5):
        L, n, m = 4, 7, 2
        masks = rng.random((L, n, n)) < 0.5
        masks[:, 3, 3] = True  # keep it feasible
        path, _ = lma_path.layered_shortest_path(masks, m)
        cost = {tuple(c): 0.0 for c in np.argwhere(masks[0])}
        for k in range(1, L):
            new: dict[tuple[int, ...], float] = {}
            for c in np.argwhere(masks[k]):
                for p, v in cost.items():
                    d = float(np.hypot(c[0] - p[0], c[1] - p[1]))
                    if d <= m + 1e-12:
                        new[tuple(c)] = min(new.get(tuple(c), np.inf), v + d)
            cost = new
        assert path is not None
        length = float(np.hypot(*np.diff(path, axis=0).T).sum())
        assert abs(length - min(cost.values())) < 1e-9


def test_unreachable_layer_is_named() -> None:
    masks = np.zeros((5, 10, 10), dtype=bool)
    masks[:3, 1, 1] = True
    masks[3:, 8, 8] = True
    path, bad = lma_path.layered_shortest_path(masks, max_step=2)
    assert path is None and bad == 3


def test_layer_offsets_round_half_up() -> None:
    off = lma_path.layer_offsets(np.array([3, -3]), 3)  # k/(L-1) = 0, 0.5, 1
    assert off.tolist() == [[0, 0], [2, -1], [3, -3]]


def test_densify_keeps_points_and_interpolates() -> None:
    xy = np.array([[[0.0, 0.0], [1.0, 2.0], [1.0, 0.0]]])
    d = lma_path.densify(xy, 4)
    assert d.shape == (1, 9, 2)
    np.testing.assert_allclose(d[0, ::4], xy[0])
    np.testing.assert_allclose(d[0, 1], [0.25, 0.5])
    np.testing.assert_array_equal(lma_path.densify(xy, 1), xy)


def test_blended_polyline_derivatives() -> None:
    way_s = np.array([0.0, 0.3, 0.5, 1.0])
    way_xy = np.array([[0.0, 0.0], [0.3, 0.1], [0.2, 0.4], [0.6, 0.5]])
    s = np.linspace(0.0, 1.0, 20001)
    h = 0.05
    xy, v, a = lma_path.blended_polyline(way_s, way_xy, s, h)
    np.testing.assert_allclose(xy[[0, -1]], way_xy[[0, -1]], atol=1e-15)
    # velocity = d(position)/ds and acceleration = d(velocity)/ds (central differences)
    ds = s[1] - s[0]
    edges = (way_s[1:-1] + np.array([[-h], [h]])).ravel()  # acceleration jumps there
    away = np.min(np.abs(s[1:-1, None] - edges), axis=1) > 2 * ds
    vel_fd = (xy[2:] - xy[:-2]) / (2 * ds)
    np.testing.assert_allclose(vel_fd[away], v[1:-1][away], atol=1e-9)
    np.testing.assert_allclose(vel_fd, v[1:-1], atol=ds * np.abs(a).max())  # C1 everywhere
    acc_fd = (v[2:] - v[:-2]) / (2 * ds)
    np.testing.assert_allclose(acc_fd[away], a[1:-1][away], atol=1e-6)
    assert np.abs(np.diff(xy, axis=0)).max() < 1e-4  # continuous position
    # outside the blends the path is the polyline; without blends it is the polyline
    xy0, _, a0 = lma_path.blended_polyline(way_s, way_xy, s, 0.0)
    far = np.min(np.abs(s[:, None] - way_s[None, 1:-1]), axis=1) >= h
    np.testing.assert_allclose(xy[far], xy0[far], atol=1e-12)
    np.testing.assert_allclose(np.interp(way_s, s, xy0[:, 0]), way_xy[:, 0], atol=1e-12)
    assert not a0.any()
