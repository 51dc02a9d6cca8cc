"""Divergence of the extended-Jacobian generator: detection, cause and the samples kept.

The generator ddq = -E^-1 (v1 + v2) ([PajakPajak] eq. (16)) is only as good as E: where the
path meets an algorithmic singularity (E singular although J is not) the velocity needed to
keep the error dynamics grows without bound within a few steps. Measured on TIAGo before the
criterion of :mod:`~mmplan.planners.extended_jacobian.posture`: |ddq| 3.6 rad/s^2 at
t = 2.20 s, 14 at 2.25, 1.9e3 at 2.30 and NaN at 2.33, while cond(E), checked every 50
steps, still read 2e3. Unchecked, the run went on as ``stalled`` with a task error of 1e13 m,
or the time scaling stretched the blown-up samples to 1e37 s and efforts of 1e8-1e298 N m.

A sample is sane while it is finite, every |dq_i| <= :data:`DQ_MAX` and every
|ddq_i| <= :data:`DDQ_MAX` (SI units of each coordinate). The papers' youBot plans stay far
below (measured: at most 42.6 rad/s and 866 rad/s^2, wheel angles, over the reproduction and
the random youbot-3r set). At the first insane sample the run ends ``diverged``; the samples
of the blow-up before it are dropped too (:func:`onset`), so that a diverged plan returns
the finite, physically meaningful part of its path.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mmplan.arrays import Array

#: Largest sane |dq_i| [m/s or rad/s] of the generator path.
DQ_MAX = 1e3
#: Largest sane |ddq_i| [m/s^2 or rad/s^2] of the generator path.
DDQ_MAX = 1e4
#: A blow-up's samples: |ddq| above this many times the run's median before it.
ONSET_FACTOR = 10.0


def insane(dq: Array, ddq: Array) -> Array:
    """Per sample (rows of dq, ddq (N, n)): not finite, or a rate over its bound (N,)."""
    dq, ddq = np.atleast_2d(dq), np.atleast_2d(ddq)
    # NaN and inf fail the comparisons too: one test per array (the rollout asks every chunk;
    # 12 us a 50-sample chunk instead of 48 with separate finiteness tests, measured)
    bad = ~np.all(np.abs(dq) <= DQ_MAX, axis=1) | ~np.all(np.abs(ddq) <= DDQ_MAX, axis=1)
    out: Array = bad
    return out


def onset(ddq: Array, stop: int) -> int:
    """First sample of the blow-up that ends at sample ``stop`` (ddq (N, n), N > stop):
    walking back from ``stop`` while |ddq| exceeds :data:`ONSET_FACTOR` times the median of
    |ddq| over the samples before ``stop``. Samples [0, onset) are kept (at least one)."""
    if stop <= 1:
        return max(stop, 1)
    peak = np.max(np.abs(ddq[:stop]), axis=1)  # (stop,)
    level = ONSET_FACTOR * max(float(np.median(peak)), 1e-9)
    k = stop
    while k > 1 and peak[k - 1] > level:
        k -= 1
    return k


def message(t: float, dq: Array, ddq: Array, coordinates: Sequence[str], cond: float | None) -> str:
    """Why the run diverged at time t (the offending coordinate and cond(E) when known)."""
    with np.errstate(invalid="ignore"):
        if not (np.all(np.isfinite(dq)) and np.all(np.isfinite(ddq))):
            what = "the generator produced NaN or inf"
        else:
            i = int(np.argmax(np.abs(ddq)))
            j = int(np.argmax(np.abs(dq)))
            if abs(ddq[i]) > DDQ_MAX:
                what = f"|ddq| of {_name(coordinates, i)} reached {abs(ddq[i]):.3g} (> {DDQ_MAX:g})"
            else:
                what = f"|dq| of {_name(coordinates, j)} reached {abs(dq[j]):.3g} (> {DQ_MAX:g})"
    where = "" if cond is None or not np.isfinite(cond) else f", cond(E) = {cond:.3g}"
    return (
        f"diverged at t = {t:.3f} s: {what}{where} (E near-singular along the path: an "
        "algorithmic singularity of the extended Jacobian); samples of the blow-up dropped"
    )


def _name(coordinates: Sequence[str], i: int) -> str:
    return coordinates[i] if i < len(coordinates) else f"q[{i}]"
