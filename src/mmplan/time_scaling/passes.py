r"""Compiled backward and forward passes of the time-optimal scaling (:mod:`.topp`).

Interval i of the path carries 2 n "slabs" lo <= a x + b v <= hi on (x_i, v_i), one per
constraint row (an actuator's effort, a coordinate's acceleration, a side of the platform's
acceleration polygon; :mod:`.rates`) at sample i (a = alpha_i, b = beta_i / 2) and at sample
i + 1 (a = alpha_{i+1}, b = alpha_{i+1} Delta_i + beta_{i+1} / 2), lo/hi = zone - g
([PajakPajak] eqs. (22), (25); first-order interpolation of TOPP-RA, Pham & Pham 2018, sec. VI).
Slabs are oriented to b >= 0 (negating a row is exact). An infinite limit is the finite bound
+-:data:`BIG`, so one build serves every pattern of finite limits. Velocity limits are not
slabs: they bound x alone, by x_upper_i at each sample (raw input).

Backward step (the reference's pair of 2D LPs): with the boxes 0 <= x <= x_upper_i, |v| <= 1e6
and the controllable set K_lo <= x + v Delta <= K_hi of i + 1, Fourier-Motzkin elimination
of v gives the controllable set of x_i exactly: the projection of a 2D polygon is the
intersection of the projections of its pairs of slabs. Slabs J, K with d = a_J b_K - a_K b_J
project to N_min <= d x <= N_max with N = c_J b_K - c_K b_J over c in [lo, hi], whose ends
are the same two-line vertices (same formula) as the reference's vertex enumeration, so the
results agree to the last bit (x within one ulp on random problems). Parallel slabs (d = 0)
give +-inf (empty when disjoint) or NaN (touching, or two slabs without v), which is
ignored; a row a = b = 0 is tested alone. Unlike the reference, nearly parallel pairs
(0 < |d| <= 1e-14) are kept (their vertex is exact, if far away).

Forward step: the largest v with every slab row of b > 1e-14 and x + v Delta in K of i + 1
(the lower bound when roundoff leaves none), x_{i+1} clipped into K of i + 1 and
[0, x_upper_{i+1}], exactly as the reference's greedy pass.

The steps read raw samples (alpha, beta, g, sigma, x_upper); the state carries the neighbouring
sample and the zone. The backward step costs O(n^2) (every pair of slabs), the forward O(n).
With a C compiler both passes run as the plain C loops of :mod:`.native` (same operations,
same results to the bit; about 1 ms for the full backward pass of a 607-sample path with 15
rows). These CasADi functions are their specification and the fallback without a compiler:
they run by ``mapaccum`` over chunks of :data:`CHUNK` intervals on CasADi's virtual machine,
inputs copied chunk by chunk into one preallocated buffer per process (so not thread-safe).
"""

from __future__ import annotations

import threading
from functools import lru_cache
from typing import Protocol

import casadi as ca
import numpy as np

from mmplan.arrays import Array
from mmplan.compile import codegen
from mmplan.time_scaling import native, native_peaks

BIG = 1e30  # stands for an infinite limit (never binds: 0 <= x <= x_upper, |v| <= 1e6)
V_BOX = 1e6  # |v| bound of the reference LP
TOL = 1e-9  # emptiness slack (the reference accepts vertices 1e-9 outside a row)
#: Intervals per call of the fallback. A call runs all of them (rows past the end feed discarded
#: steps), so a backward pass restarted at interval m (the re-timing rounds, :mod:`.retime`)
#: costs ceil((m + 1) / CHUNK) calls.
CHUNK = 64
#: Above this many rows the backward step projects its slab pairs by one mapped function
#: instead of straight-line code (a smaller expression graph; when these functions were
#: compiled, gcc took 28 s for the straight-line step of 14 rows, 2.4 s mapped).
MAPPED_ABOVE = 8
RAW = 3  # (n,) blocks of a raw sample: alpha, beta, g; then sigma and x_upper

Slab = tuple[ca.SX, ca.SX, ca.SX, ca.SX]


class _Chunk(Protocol):
    """A chunk pass: flat input vector ``x`` in, flat output vector out."""

    x: Array

    def __call__(self) -> Array: ...


class _VMChunk:
    """CasADi-VM stand-in for :class:`codegen.NativeFunction` (same interface)."""

    def __init__(self, fn: ca.Function) -> None:
        self.fn = fn
        self.x = np.zeros(fn.size1_in(0))

    def __call__(self) -> Array:
        return np.asarray(self.fn(self.x), dtype=float).ravel()


def _min(a: ca.SX, b: ca.SX) -> ca.SX:
    """Python's ``min(a, b)``: a unless b < a (a NaN b is ignored). A select: C compiles it
    without the libm call of ``fmin`` (backward pass 1.3-2.5x faster, measured)."""
    return ca.if_else(b < a, b, a)


def _max(a: ca.SX, b: ca.SX) -> ca.SX:
    """Python's ``max(a, b)``: a unless b > a (a NaN b is ignored)."""
    return ca.if_else(b > a, b, a)


def _oriented(a: ca.SX, b: ca.SX, lo: ca.SX, hi: ca.SX) -> Slab:
    """The slab lo <= a x + b v <= hi with b >= 0; a row a = b = 0 becomes no bound when
    lo <= 0 <= hi (within TOL), else stays empty (lo > 0 or hi < 0 with d = 0: +-inf)."""
    flip = b < 0
    a, lo, hi = ca.if_else(flip, -a, a), ca.if_else(flip, -hi, lo), ca.if_else(flip, -lo, hi)
    b = ca.fabs(b)
    zero = ca.logic_and(a == 0, b == 0)
    lo = ca.if_else(ca.logic_and(zero, lo <= TOL), -BIG, lo)
    hi = ca.if_else(ca.logic_and(zero, hi >= -TOL), BIG, hi)
    return a, b, lo, hi


def _interval(start: ca.SX, end: ca.SX, lo: ca.SX, hi: ca.SX, n: int) -> tuple[list[Slab], ca.SX]:
    """Oriented slabs of the interval between raw samples [alpha, beta, g, sigma, x_upper]."""
    delta = end[3 * n] - start[3 * n]
    slabs = []
    for k in range(n):
        slabs.append(_oriented(start[k], 0.5 * start[n + k], lo[k] - start[2 * n + k],
                               hi[k] - start[2 * n + k]))  # fmt: skip
    for k in range(n):
        b = end[k] * delta + 0.5 * end[n + k]
        slabs.append(_oriented(end[k], b, lo[k] - end[2 * n + k], hi[k] - end[2 * n + k]))
    return slabs, delta


def _pair(s: Slab, t: Slab) -> tuple[ca.SX, ca.SX]:
    """Bounds (x_lo, x_hi) of the projection of the oriented slabs s, t (module docstring):
    with b >= 0 the extreme N are lo_s b_t - hi_t b_s and hi_s b_t - lo_t b_s."""
    a1, b1, lo1, hi1 = s
    a2, b2, lo2, hi2 = t
    det = a1 * b2 - a2 * b1
    r1 = (lo1 * b2 - hi2 * b1) / det
    r2 = (hi1 * b2 - lo2 * b1) / det
    pos = det >= 0
    return ca.if_else(pos, r1, r2), ca.if_else(pos, r2, r1)


def backward_step(n: int) -> ca.Function:
    """(state of i + 1, raw sample i) -> (state of i, [K_lo, K_hi, empty] of i).

    State: [K_lo, K_hi, lo (n), hi (n), raw sample] with the zone lo/hi (+-BIG when
    infinite) and raw samples [alpha (n), beta (n), g (n), sigma, x_upper].
    """
    r = RAW * n + 2
    state, raw = ca.SX.sym("s", 2 + 2 * n + r), ca.SX.sym("raw", r)
    lo, hi = state[2 : 2 + n], state[2 + n : 2 + 2 * n]
    slabs, delta = _interval(raw, state[2 + 2 * n :], lo, hi, n)
    slabs.append((ca.SX(0.0), ca.SX(1.0), ca.SX(-V_BOX), ca.SX(V_BOX)))
    slabs.append((ca.SX(1.0), delta, state[0], state[1]))
    if n > MAPPED_ABOVE:
        return _mapped_backward_step(state, raw, slabs, n)
    x_lo, x_hi = ca.SX(0.0), raw[r - 1]
    for j in range(len(slabs)):
        for k in range(j + 1, len(slabs)):
            lo_jk, hi_jk = _pair(slabs[j], slabs[k])
            x_lo, x_hi = _max(x_lo, lo_jk), _min(x_hi, hi_jk)
    x_hi = _max(x_hi, ca.SX(-BIG))  # -inf (parallel, disjoint) would make the slack NaN
    empty = x_lo > x_hi + TOL * (1.0 + ca.fabs(x_hi))
    k_lo = _max(_min(x_lo, x_hi), ca.SX(0.0))
    new = ca.vertcat(k_lo, x_hi, state[2 : 2 + 2 * n], raw)
    return ca.Function("ej_topp_bw", [state, raw], [new, ca.vertcat(k_lo, x_hi, empty)])


def _mapped_backward_step(state: ca.SX, raw: ca.SX, slabs: list[Slab], n: int) -> ca.Function:
    """:func:`backward_step` with the pair projections of :func:`_pair` in one function mapped
    over the pairs (same values: NaN bounds are dropped, as :func:`_min` and :func:`_max`
    drop them, and min/max are exact in any order)."""
    s, t = ca.SX.sym("s", 4), ca.SX.sym("t", 4)
    lo, hi = _pair((s[0], s[1], s[2], s[3]), (t[0], t[1], t[2], t[3]))
    lo, hi = ca.if_else(lo == lo, lo, -ca.inf), ca.if_else(hi == hi, hi, ca.inf)
    pair = ca.Function("ej_topp_pair", [s, t], [ca.vertcat(lo, hi)])
    S = ca.horzcat(*[ca.vertcat(*slab) for slab in slabs])  # (4, slabs)
    prepare = ca.Function("ej_topp_slabs", [state, raw], [S])
    st, rw = ca.MX.sym("s", state.numel()), ca.MX.sym("raw", raw.numel())
    S_mx = prepare(st, rw)
    first, second = zip(*[(j, k) for j in range(len(slabs)) for k in range(j + 1, len(slabs))],
                        strict=True)  # fmt: skip
    bounds = pair.map(len(first))(S_mx[:, list(first)], S_mx[:, list(second)])
    x_lo = ca.fmax(0.0, ca.mmax(bounds[0, :]))
    x_hi = ca.fmin(rw[rw.numel() - 1], ca.mmin(bounds[1, :]))
    x_hi = ca.fmax(x_hi, -BIG)  # -inf (parallel, disjoint) would make the slack NaN
    empty = x_lo > x_hi + TOL * (1.0 + ca.fabs(x_hi))
    k_lo = ca.fmax(ca.fmin(x_lo, x_hi), 0.0)
    new = ca.vertcat(k_lo, x_hi, st[2 : 2 + 2 * n], rw)
    return ca.Function("ej_topp_bw", [st, rw], [new, ca.vertcat(k_lo, x_hi, empty)])


def forward_step(n: int) -> ca.Function:
    """(state of i, [raw sample i + 1, K_lo, K_hi of i + 1]) -> (state of i + 1, x_{i+1}).

    State: [x, lo (n), hi (n), raw sample] (as :func:`backward_step`).
    """
    r = RAW * n + 2
    state, col = ca.SX.sym("s", 1 + 2 * n + r), ca.SX.sym("c", r + 2)
    x, lo, hi = state[0], state[1 : 1 + n], state[1 + n : 1 + 2 * n]
    slabs, delta = _interval(state[1 + 2 * n :], col[:r], lo, hi, n)
    v_hi, v_lo = (col[r + 1] - x) / delta, (col[r] - x) / delta
    for a, b, s_lo, s_hi in slabs:
        use, ax = b > 1e-14, a * x
        v_hi = _min(v_hi, ca.if_else(use, (s_hi - ax) / b, BIG))
        v_lo = _max(v_lo, ca.if_else(use, (s_lo - ax) / b, -BIG))
    x_next = _min(_max(x + _max(v_hi, v_lo) * delta, col[r]), col[r + 1])  # stay in K
    x_next = _min(_max(x_next, ca.SX(0.0)), col[r - 1])
    new = ca.vertcat(x_next, state[1 : 1 + 2 * n], col[:r])
    return ca.Function("ej_topp_fw", [state, col], [new, x_next])


def _flat(step: ca.Function, name: str, n: int) -> ca.Function:
    """``step`` mapaccum'ed over CHUNK columns, one flat input [state, alpha (CHUNK, n),
    beta, g, sigma (CHUNK,), x_upper (CHUNK,), extra columns (CHUNK,) ...] and one flat output
    [last state, outputs (CHUNK,) one after the other]."""
    n_s, n_c = step.size1_in(0), step.size1_in(1)
    z = ca.MX.sym("z", n_s + n_c * CHUNK)
    cols, at = [], n_s
    for rows in [n] * RAW + [1] * (n_c - RAW * n):
        cols.append(ca.reshape(z[at : at + rows * CHUNK], rows, CHUNK))
        at += rows * CHUNK
    states, out = step.mapaccum(f"{name}_acc", CHUNK, 1)(z[:n_s], ca.vertcat(*cols))
    return ca.Function(name, [z], [ca.vertcat(states[:, -1], ca.vec(out.T))])


def _names(n: int) -> tuple[str, str]:
    return f"ej_topp_bw{n}", f"ej_topp_fw{n}"


def _make(n: int) -> list[ca.Function]:
    """The (backward, forward) chunk functions for n rows."""
    names = _names(n)
    return [_flat(backward_step(n), names[0], n), _flat(forward_step(n), names[1], n)]


@lru_cache(maxsize=8)
def passes(n: int) -> tuple[_Chunk, _Chunk]:
    """(backward, forward) chunk passes for n constraint rows on CasADi's virtual machine: the
    fallback when the C loops of :mod:`.native` cannot be built (no compiler)."""
    bw, fw = _make(n)
    return _VMChunk(bw), _VMChunk(fw)


#: The build :func:`prefetch` started and nobody has waited for yet.
_PENDING: list[threading.Thread] = []


def prefetch() -> None:
    """Build the C loops of the time scaling in a background thread while the caller compiles
    something else (the first plan of a robot: the generator's library): the passes of
    :mod:`.native` and the step peaks of :mod:`.native_peaks` (about 0.2 s each, once per
    machine; they serve every row count; the first scaling waits for the thread, the peaks
    are used after it). A no-op when they are cached or being built, or without a compiler."""
    if not _missing() or _on_disk():  # on disk: loaded at first use or by :func:`load`
        return
    _PENDING.append(codegen.in_background(_load_both))


def _missing() -> bool:
    """Not loaded, not being built, and a compiler to build them."""
    return not (_PENDING or native.kernels.cache_info().currsize or codegen.compiler() is None)


def _on_disk() -> bool:
    return all(codegen.source_is_cached(m.SOURCE, m.PREFIX, m.FLAGS, m.FALLBACK)
               for m in (native, native_peaks))  # fmt: skip


def _load_both() -> None:
    """Build or load both libraries (lru_cached by their modules)."""
    native.kernels()
    native_peaks.peaks()


def load_passes() -> None:
    """Load the passes of :mod:`.native` when they are on disk (a caller with idle time: the
    rollout waiting for its compiled chunks,
    :mod:`mmplan.planners.extended_jacobian.prefetch`); else leave them to :func:`prefetch` or
    the first scaling. The step peaks apart (:func:`load_peaks`): one idle wait may not hold
    both."""
    if _missing() and codegen.source_is_cached(native.SOURCE, native.PREFIX, native.FLAGS,
                                               native.FALLBACK):  # fmt: skip
        native.kernels()


def load_peaks() -> None:
    """Load the step peaks of :mod:`.native_peaks` when they are on disk (as
    :func:`load_passes`)."""
    if (
        not (_PENDING or native_peaks.peaks.cache_info().currsize or codegen.compiler() is None)
        and codegen.source_is_cached(native_peaks.SOURCE, native_peaks.PREFIX,
                                     native_peaks.FLAGS, native_peaks.FALLBACK)
    ):  # fmt: skip
        native_peaks.peaks()


def kernels() -> native.Kernels | None:
    """The C loops (after a build :func:`prefetch` started has finished), None without them."""
    while _PENDING:
        _PENDING.pop().join()
    return native.kernels()


def _fill(buf: Array, columns: list[Array], sel: slice) -> None:
    """Copy rows ``sel`` of each column array into the chunk buffer (stale rows past the
    end are left: they only feed discarded steps)."""
    at = 0
    for col in columns:
        width = col.shape[1] if col.ndim == 2 else 1
        block = buf[at : at + width * CHUNK].reshape(CHUNK, width)
        rows = col[sel]
        block[: len(rows)] = rows.reshape(len(rows), width)
        at += width * CHUNK


def backward(
    alpha: Array,
    beta: Array,
    g: Array,
    sigma: Array,
    x_upper: Array,
    zone: Array,
    last: tuple[float, float],
    start: int | None = None,
) -> tuple[Array, Array, Array]:
    """K_lo, K_hi and the empty flags of samples 0 .. ``start`` (default N - 2), from ``last``
    = [K_lo, K_hi] of sample ``start`` + 1; ``zone`` = [lo (n), hi (n)] with +-BIG for
    infinite limits. The same steps give the same values whatever the first interval."""
    n = alpha.shape[1]
    N = len(alpha) if start is None else start + 2
    compiled = kernels()
    if compiled is not None:
        return compiled.backward(alpha, beta, g, sigma, x_upper, zone, last, N - 2)
    chunk = passes(n)[0]
    n_s = 2 + 2 * n + RAW * n + 2
    k = N - 1
    state = np.concatenate([last, zone, alpha[k], beta[k], g[k], sigma[k : k + 1],
                            x_upper[k : k + 1]])  # fmt: skip
    out = np.empty((3, N - 1))
    for top in range(N - 2, -1, -CHUNK):  # intervals top, top - 1, ..., top - CHUNK + 1
        sel = slice(top, top - CHUNK if top >= CHUNK else None, -1)
        chunk.x[:n_s] = state
        _fill(chunk.x[n_s:], [alpha, beta, g, sigma, x_upper], sel)
        y = chunk()
        state = y[:n_s].copy()
        count = min(CHUNK, top + 1)
        out[:, top - count + 1 : top + 1] = y[n_s:].reshape(3, CHUNK)[:, count - 1 :: -1]
    return out[0], out[1], out[2]


def forward(
    alpha: Array,
    beta: Array,
    g: Array,
    sigma: Array,
    x_upper: Array,
    zone: Array,
    K_lo: Array,
    K_hi: Array,
    x_start: float = 0.0,
) -> Array:
    """x_1 .. x_{N-1} of the greedy pass from x_0 = ``x_start`` (``zone`` as :func:`backward`)."""
    N, n = alpha.shape
    compiled = kernels()
    if compiled is not None:
        return compiled.forward(alpha, beta, g, sigma, x_upper, zone, K_lo, K_hi, x_start)
    chunk = passes(n)[1]
    n_s = 1 + 2 * n + RAW * n + 2
    state = np.concatenate([[x_start], zone, alpha[0], beta[0], g[0], sigma[:1], x_upper[:1]])
    x = np.empty(N - 1)
    for first in range(1, N, CHUNK):  # samples first .. first + CHUNK - 1
        sel = slice(first, first + CHUNK)
        chunk.x[:n_s] = state
        _fill(chunk.x[n_s:], [alpha, beta, g, sigma, x_upper, K_lo, K_hi], sel)
        y = chunk()
        state = y[:n_s].copy()
        count = min(CHUNK, N - first)
        x[first - 1 : first - 1 + count] = y[n_s : n_s + count]
    return x
