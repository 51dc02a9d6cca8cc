r"""Numerics of the Barr superellipsoid: gauge function and exact point-to-surface distance.

In local, per-axis scaled coordinates u = p' / a (p' = R^T (p - c)), Barr's inside-outside
function is F = (|u1|^P + |u2|^P)^(Q/P) + |u3|^Q with P = 2/e2, Q = 2/e1
(docs/conventions.md). Its gauge (Minkowski functional)

.. math::  G(u) = F(u)^{e_1/2} = \| (\rho(u_1, u_2), u_3) \|_Q,\quad
           \rho = \| (u_1, u_2) \|_P

is a nested power norm, positively homogeneous of degree 1 and convex for exponents <= 2; the
solid is G <= 1. Everything below works in the positive octant (|p'| componentwise): the shape
is symmetric in each coordinate plane, so the nearest surface point of a folded point lies in
the closed positive octant and the distance is unchanged by folding.

Exact distance (:func:`signed_distance`):

1. seed: nearest point of a dense surface sample (radial projection of a cube-map grid of
   directions, 3 n^2 points per octant, n = 48; n = 192 for points inside, whose distance can
   have several nearly equal local minima) found with a ``scipy.spatial.cKDTree``;
2. refine: Newton's method on the closest-point (KKT) conditions
   q - p + mu grad G(q) = 0, G(q) = 1 (unknowns q (3), mu), with the analytic gradient and
   Hessian of G, steps limited to a quarter of the smallest semi-axis, iterates kept in the
   octant, until the step is below 1e-13 m (at most 60 iterations);
3. every iterate is projected radially onto the surface (q / G(q), an exact surface point), so
   |p - q| is a valid upper bound of the distance; the smallest one is returned;
4. exponents > 1 only: the surface has unbounded curvature (an edge at 2) where it meets a
   coordinate plane, where Newton stalls or crawls; points whose Newton did not converge or
   whose nearest point lies within 0.02 (scaled) of such a plane are polished by a compass
   search that also tries candidates snapped onto the planes.

Accuracy (tests/scene/test_superellipsoid.py, against an independent brute-force reference,
exponents (0.1, 1), (1, 1), (0.1, 0.1), (0.6, 0.4), (1.5, 0.5), (2, 2)): within 1e-6 m
inside and outside; the reference (itself an upper bound) is never beaten by more than 1e-9 m.
Outside, the other critical points of the distance on a convex surface face away from the
point and are far worse than the nearest sample, so Newton finds the projection. Inside, the
distance can have several local minima; a wrong basin needs two minima closer in value than
the fine seed's error (~1e-5 m for 0.3 m semi-axes); not seen in the tests.
Seeds of outside points come from an approximate k-d tree query (within 5 %: the exact query
is slow far from flat faces, where many samples are nearly equidistant); a result is kept only
when certified (Newton converged with mu > 0: p - q along the outward normal, which on a
convex body makes q the projection), else the point is redone with exact seeds.
Cost (1e5 random points in a 4 x 4 x 1.2 m box, shared 2-core machine): 0.5 s for the cylinder
model of [PajakPajak] (1.4 s with exact seeds), 0.35-0.6 s for other exponents <= 1; exponents
> 1 are much slower, 20-35 s per 1e5 points (the compass search).
"""

from __future__ import annotations

from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

from mmplan.arrays import Array

if TYPE_CHECKING:
    from scipy.spatial import cKDTree


_TINY = 1e-12  # lower clip of ratios raised to negative powers (exponents > 1)
_SAMPLE_N = 48  # cube-map grid size per face of the seed sample
_FINE_N = 192  # finer seed sample for points inside
_MAX_ITER = 60
_FAR = 1e12  # m: beyond this a point's distance is its distance from the centre
_TOL = 1e-13  # Newton step size [m] below which a point is converged
_SEED_EPS = 0.05  # relative tolerance of the approximate seed query for outside points
_PATTERN_ITER = 400
_PLANE_BAND = 0.02  # scaled distance to a coordinate plane below which exponents > 1 polish
# Masks applied to pattern candidates: keep all coordinates, zero one, zero two.
_SNAP = np.array(
    [[1, 1, 1], [0, 1, 1], [1, 0, 1], [1, 1, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float
)[:, None, :]


def gauge(u: Array, P: float, Q: float) -> Array:
    """Gauge G of nonnegative scaled points u (N, 3); overflow-safe by homogeneity."""
    m = u.max(axis=1)
    safe = np.where(m > 0.0, m, 1.0)
    t = u / safe[:, None]
    with np.errstate(under="ignore"):
        rho = (t[:, 0] ** P + t[:, 1] ** P) ** (1.0 / P)  # in [0, 2^(1/P)]: rescale again
        m2 = np.maximum(rho, t[:, 2])  # so that a large Q (tiny e1) cannot overflow
        safe2 = np.where(m2 > 0.0, m2, 1.0)
        g = m2 * ((rho / safe2) ** Q + (t[:, 2] / safe2) ** Q) ** (1.0 / Q)
    return np.asarray(g * m, dtype=float)


def gauge_derivatives(u: Array, P: float, Q: float) -> tuple[Array, Array, Array]:
    """G (N,), gradient (N, 3) and Hessian (N, 3, 3) w.r.t. scaled points u >= 0 (N, 3).

    Chain rule through the nested norms: with N_r(x) = ||x||_r, grad N_r = (x / N_r)^(r-1)
    and Hess N_r = (r - 1)/N_r (diag((x/N_r)^(r-2)) - grad grad^T).
    """
    with np.errstate(under="ignore", over="ignore"):
        rho = np.maximum((u[:, 0] ** P + u[:, 1] ** P) ** (1.0 / P), _TINY)
        g = np.maximum((rho**Q + u[:, 2] ** Q) ** (1.0 / Q), _TINY)
        s = np.maximum(u[:, :2] / rho[:, None], _TINY)  # (N, 2)
        r = s ** (P - 1.0)  # grad rho (N, 2)
        y = np.maximum(np.stack([rho, u[:, 2]], axis=1) / g[:, None], _TINY)  # (N, 2)
        c = y ** (Q - 1.0)  # grad of G w.r.t. (rho, u3) (N, 2)
        k_rho = (P - 1.0) / rho
        k_g = (Q - 1.0) / g
        hy00 = k_g * (y[:, 0] ** (Q - 2.0) - c[:, 0] ** 2)
        hy01 = -k_g * c[:, 0] * c[:, 1]
        hy11 = k_g * (y[:, 1] ** (Q - 2.0) - c[:, 1] ** 2)
        hr = k_rho * c[:, 0]  # G_rho * (P - 1) / rho
        sp = s ** (P - 2.0)
    grad = np.empty_like(u)
    grad[:, :2] = c[:, :1] * r
    grad[:, 2] = c[:, 1]
    hess = np.empty((u.shape[0], 3, 3))
    hess[:, 0, 0] = hy00 * r[:, 0] ** 2 + hr * (sp[:, 0] - r[:, 0] ** 2)
    hess[:, 1, 1] = hy00 * r[:, 1] ** 2 + hr * (sp[:, 1] - r[:, 1] ** 2)
    hess[:, 0, 1] = hess[:, 1, 0] = (hy00 - hr) * r[:, 0] * r[:, 1]
    hess[:, 0, 2] = hess[:, 2, 0] = hy01 * r[:, 0]
    hess[:, 1, 2] = hess[:, 2, 1] = hy01 * r[:, 1]
    hess[:, 2, 2] = hy11
    return g, grad, hess


@lru_cache(maxsize=16)
def _seed_tree(
    semi_axes: tuple[float, float, float], P: float, Q: float, n: int = _SAMPLE_N
) -> tuple[Array, cKDTree]:
    """Dense surface sample of the positive octant (physical local units) and its k-d tree."""
    s = np.linspace(0.0, 1.0, n)
    a, b = (m.ravel() for m in np.meshgrid(s, s))
    one = np.ones_like(a)
    dirs = np.concatenate(
        [np.stack(c, axis=1) for c in ((one, a, b), (a, one, b), (a, b, one))], axis=0
    )
    surf = dirs / gauge(dirs, P, Q)[:, None] * np.asarray(semi_axes)
    from scipy.spatial import cKDTree  # lazy: 0.2 s to import, needed only here

    return surf, cKDTree(surf)


def signed_distance(
    local: Array,
    semi_axes: tuple[float, float, float],
    e1: float,
    e2: float,
    approximate_seeds: bool = True,
) -> Array:
    """Exact signed distance from local points p' (N, 3) to the superellipsoid surface (N,).

    Method and accuracy in the module docstring. With ``approximate_seeds`` the seeds of
    outside points come from an approximate k-d tree query (within 5 %, several times
    faster far from the shape); points whose answer is then not certified are redone with
    exact seeds. A non-finite point gets NaN; a point farther than ``_FAR`` [m] gets its
    distance from the centre (the surface is negligibly small at that range, and the k-d tree
    cannot square such coordinates).
    """
    local = np.asarray(local, dtype=float)
    finite = np.isfinite(local).all(axis=1)
    radius = np.full(local.shape[0], np.nan)
    radius[finite] = np.linalg.norm(local[finite], axis=1)
    near = finite & (radius < _FAR)
    if near.all():
        return _signed_distance_near(local, semi_axes, e1, e2, approximate_seeds)
    out = radius.copy()  # NaN where not finite, |p| where far
    if near.any():
        out[near] = _signed_distance_near(local[near], semi_axes, e1, e2, approximate_seeds)
    return out


def _signed_distance_near(
    local: Array,
    semi_axes: tuple[float, float, float],
    e1: float,
    e2: float,
    approximate_seeds: bool,
) -> Array:
    """:func:`signed_distance` for finite points within ``_FAR`` of the centre."""
    P, Q = 2.0 / e2, 2.0 / e1
    a = np.asarray(semi_axes, dtype=float)
    p = np.abs(local)
    inside = gauge(p / a, P, Q) < 1.0
    key = (float(a[0]), float(a[1]), float(a[2]))
    surf, tree = _seed_tree(key, P, Q)
    best, idx = tree.query(p, eps=_SEED_EPS if approximate_seeds else 0.0)
    best = np.asarray(best, dtype=float)
    q = surf[idx].copy()
    if inside.any():  # inside points may have close local minima: seed them from a finer sample
        fine_surf, fine_tree = _seed_tree(key, P, Q, _FINE_N)
        fine_best, fine_idx = fine_tree.query(p[inside])
        best[inside] = fine_best
        q[inside] = fine_surf[fine_idx]
    best_q = q.copy()
    max_step = 0.25 * float(a.min())

    g, grad_u, _ = gauge_derivatives(q / a, P, Q)
    grad = grad_u / a
    mu = np.einsum("ni,ni->n", p - q, grad) / np.einsum("ni,ni->n", grad, grad)
    active = np.arange(p.shape[0])
    for _ in range(_MAX_ITER):
        if active.size == 0:
            break
        pa, qa, ma = p[active], q[active], mu[active]
        g, grad_u, hess_u = gauge_derivatives(qa / a, P, Q)
        grad = grad_u / a
        hess = hess_u / (a[:, None] * a[None, :])
        kkt = np.zeros((active.size, 4, 4))
        kkt[:, :3, :3] = np.eye(3) + ma[:, None, None] * hess
        kkt[:, :3, 3] = grad
        kkt[:, 3, :3] = grad
        rhs = np.concatenate([qa - pa + ma[:, None] * grad, (g - 1.0)[:, None]], axis=1)
        step = -_solve(kkt, rhs)
        dq = step[:, :3]
        norm = np.linalg.norm(dq, axis=1)
        scale = np.minimum(1.0, max_step / np.maximum(norm, 1e-300))
        qa = np.maximum(qa + scale[:, None] * dq, 0.0)
        ma = ma + scale * step[:, 3]
        gq = gauge(qa / a, P, Q)
        ok = gq > 0.0
        proj = qa / np.where(ok, gq, 1.0)[:, None]
        dist = np.where(ok, np.linalg.norm(pa - proj, axis=1), np.inf)
        better = dist < best[active]
        best[active[better]] = dist[better]
        best_q[active[better]] = proj[better]
        q[active], mu[active] = qa, ma
        active = active[norm * scale > _TOL * max(1.0, float(a.max()))]
    if approximate_seeds:
        # Certificate: outside a convex body, a KKT point with p - q along the outward normal
        # (mu > 0) is the projection. Anything else is redone from exact nearest samples.
        redo = ~inside & (mu <= 0.0)
        redo[active] |= ~inside[active]
        if redo.any():
            best[redo] = signed_distance(local[redo], semi_axes, e1, e2, False)
            active = active[~redo[active]]
            best_q[redo] = np.inf  # keep them out of the polish below (already polished)
    if max(e1, e2) > 1.0:
        # Polish where Newton is unreliable: not converged, or nearest point close to a
        # coordinate plane (unbounded curvature there, an edge at exponent 2).
        suspect = np.zeros(p.shape[0], dtype=bool)
        suspect[active] = True
        suspect |= (best_q / a).min(axis=1) < _PLANE_BAND
        suspect &= np.isfinite(best_q[:, 0])
        if suspect.any():
            best[suspect] = np.minimum(
                best[suspect], _pattern_search(p[suspect], best_q[suspect], a, P, Q)
            )
    return np.where(inside, -best, best)


def _pattern_search(p: Array, start: Array, a: Array, P: float, Q: float) -> Array:
    """Derivative-free polish of the distance from p (N, 3) to the surface, from ``start``.

    Used for exponents > 1, where the surface has unbounded curvature (or edges at 2) where
    it meets a coordinate plane and Newton may stall there. Compass search over surface points
    a d / G(d) around the current direction d, on a 3 x 3 pattern in the tangent plane of d
    rotated by the golden angle each iteration (so that edges do not stall it), halving the
    step when no neighbour improves, down to 1e-10 (scaled units).
    """
    n = p.shape[0]
    rows = np.arange(n)
    d = start / a
    value = np.linalg.norm(p - start, axis=1)
    h = np.full(n, 2.0 / _SAMPLE_N)
    offsets = np.array([(i, j) for i in (-1, 0, 1) for j in (-1, 0, 1) if (i, j) != (0, 0)], float)
    for k in range(_PATTERN_ITER):
        active = np.flatnonzero(h > 1e-10)
        if active.size == 0:
            break
        angle = 2.399963229728653 * k
        rot = offsets @ np.array([[np.cos(angle), np.sin(angle)], [-np.sin(angle), np.cos(angle)]])
        da = d[active]
        unit = da / np.linalg.norm(da, axis=1)[:, None]
        helper = np.where(unit[:, :1] < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
        t1 = np.cross(unit, helper)
        t1 /= np.linalg.norm(t1, axis=1)[:, None]
        t2 = np.cross(unit, t1)
        move = rot[None, :, :1] * t1[:, None, :] + rot[None, :, 1:] * t2[:, None, :]
        cand = np.abs(da[:, None, :] + h[active, None, None] * move)  # (m, 8, 3)
        # Also try each candidate snapped onto the coordinate planes: the minimum often lies
        # on such a plane (an edge of the folded surface), a line no pattern would hit.
        cand = np.concatenate([cand * mask for mask in _SNAP], axis=1).reshape(-1, 3)
        g = gauge(cand, P, Q)
        cand = cand / np.where(g > 0.0, g, 1.0)[:, None]
        dist = np.linalg.norm((cand * a).reshape(active.size, -1, 3) - p[active, None, :], axis=2)
        dist[(g <= 0.0).reshape(active.size, -1)] = np.inf
        j = np.argmin(dist, axis=1)
        new = dist[rows[: active.size], j]
        improve = new < value[active]
        d[active[improve]] = cand.reshape(active.size, -1, 3)[rows[: active.size], j][improve]
        value[active[improve]] = new[improve]
        h[active[~improve]] *= 0.5
    return value


def _solve(mat: Array, rhs: Array) -> Array:
    """Batched solve of (N, 4, 4) systems; singular ones get a least-squares answer."""
    try:
        return np.asarray(np.linalg.solve(mat, rhs[:, :, None])[:, :, 0], dtype=float)
    except np.linalg.LinAlgError:
        out = np.empty_like(rhs)
        for i in range(rhs.shape[0]):
            out[i] = np.linalg.lstsq(mat[i], rhs[i], rcond=None)[0]
        return out
