"""The compiled extended-Jacobian generator as Python sees it: :class:`GeneratorFunctions`.

Built by :func:`mmplan.planners.extended_jacobian.generator.build_functions` (which documents every
function);
here are the NumPy-facing calls: one sample's terms, the time-scaling coefficients at many
samples, one step, and a chunk of steps (through ctypes when compiled).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from mmplan.arrays import Array
from mmplan.compile import codegen as cg
from mmplan.compile import threads
from mmplan.planners.extended_jacobian.parameters import ParameterLayout
from mmplan.planners.extended_jacobian.prefetch import Speculation, speculation_of
from mmplan.planners.extended_jacobian.step import CHUNK


@dataclass(frozen=True)
class Terms:
    """Outputs of ``terms`` at one state as NumPy (names as in the module docstring)."""

    f0: Array
    fv: Array
    fp: Array
    S: float
    T0: Array
    Tm: Array
    err: float
    Tg: Array
    gK: Array  # noqa: N815


class LazyFunction:
    """A CasADi function built on its first call (``build() -> ca.Function``)."""

    def __init__(self, build: Callable[[], ca.Function]) -> None:
        self._build = build
        self._fn: ca.Function | None = None

    def __call__(self, *args: Any) -> Any:
        return self.function(*args)

    @property
    def function(self) -> ca.Function:
        """The built function."""
        if self._fn is None:
            self._fn = self._build()
        return self._fn

    def __getattr__(self, name: str) -> Any:  # size1_in, n_instructions, ...: the function's
        if name.startswith("_"):
            raise AttributeError(name)
        return getattr(self.function, name)


@dataclass
class GeneratorFunctions:
    """The generator functions and their sizes (see the module docstring).

    ``terms`` and ``step`` are the SX reference functions (``step`` only when not compiled);
    ``effort`` maps x = [q; dq] to [Tm dq; Tg] (compiled with the others);
    ``terms_flat`` (x = [q; dq; p]) and ``step_flat`` (x = [q; dq; u; s; ext; p; dt])
    compute the same with one input and one output each (one NumPy conversion a call),
    compiled to C when ``compiled`` (then ``step_flat`` is the fused step of
    :mod:`~mmplan.planners.extended_jacobian.step`, equal to rounding); ``chunk`` runs
    ``chunk_steps`` steps with records in one call.
    """

    step: ca.Function | LazyFunction | None  # SX reference step (None when compiled)
    terms: ca.Function | LazyFunction  # lazy when loaded from the disk cache (compiled.py)
    E: ca.Function | LazyFunction
    n: int
    n_act: int
    compiled: bool
    terms_flat: ca.Function | LazyFunction
    step_flat: ca.Function | LazyFunction
    effort: ca.Function | LazyFunction  # [q; dq] -> [Tm dq; Tg] (time scaling)
    chunk: ca.Function | LazyFunction | None = None
    chunk_steps: int = CHUNK
    #: The fused step (x, par) -> (x_next, rec) of step.py.
    record: ca.Function | LazyFunction | None = None
    native_chunk: Any = None  # cg.NativeFunction of chunk_flat (step.build_chunk_flat)
    _last: Array | None = None
    cache: dict[str, Any] = field(default_factory=dict)  # functions built later (torque.feedback)
    #: Where goal, gains, floor, obstacle slots and partition lie in p (parameters.py).
    layout: ParameterLayout = field(default_factory=ParameterLayout)
    #: Disk-cache key of the compiled library ("" when not compiled or keyed by its model).
    key: str = ""
    #: Path of the compiled library ("" on the virtual machine): ``E``, ``terms_flat`` and
    #: ``effort`` are then called through ctypes (:meth:`_native`), not ``casadi.external``.
    library: str = ""

    def _native(self, name: str) -> Any:
        """The compiled ``mmplan_ej_<name>`` as a ctypes call (made on first use), None on the
        virtual machine."""
        if not self.library:
            return None
        key = f"native_{name}"
        if key not in self.cache:
            try:
                self.cache[key] = cg.NativeFunction(self.library, f"mmplan_ej_{name}")
            except (OSError, AttributeError, ValueError):  # not callable so: CasADi's call
                self.cache[key] = None
        return self.cache[key]

    def E_at(self, q: Array, p: Array) -> Array:
        """E(q) (n, n) with parameters p."""
        native = self._native("E")
        if native is None:
            return np.asarray(self.E(q, p), dtype=float)
        n = self.n
        native.x[:n] = q
        native.x[n:] = p
        native()
        return native.dense()

    def evaluate(self, q: Array, dq: Array, p: Array) -> Terms:
        """``terms`` at (q, dq) with parameters p (``layout``)."""
        native = self._native("terms_flat")
        if native is None:
            v = self.terms_flat(np.concatenate([q, dq, p])).full().ravel()
        else:
            native.x[:] = np.concatenate([q, dq, p])
            native()
            v = native.dense().ravel(order="F")
        n, a = self.n, self.n_act
        cut = np.cumsum([n, n, n, 1, a, a * n, 1, a])
        f0, fv, fp, S, T0, Tm, err, Tg, gK = np.split(v, cut)
        return Terms(f0, fv, fp, float(S[0]), T0, Tm.reshape(n, a).T, float(err[0]), Tg, gK)

    def evaluate_many(self, Q: Array, DQ: Array) -> tuple[Array, Array]:
        """beta = Tm dq and Tg (each (N, n_act)) at N states (rows of Q, DQ), one call of
        ``effort`` (the coefficients of the time scaling,
        :mod:`~mmplan.planners.extended_jacobian.time_scaling`, when the
        compiled chunks did not record them)."""
        N = len(Q)
        X = np.vstack([np.asarray(Q, dtype=float).T, np.asarray(DQ, dtype=float).T])
        V = np.asarray(self.effort.map(N)(X))
        a = self.n_act
        return np.ascontiguousarray(V[:a].T), np.ascontiguousarray(V[a:].T)

    def ee_positions(self, Q: Array) -> Array | None:
        """End-effector positions at the states Q (N, n) -> (N, 3) by the compiled ``ee_flat``
        (``chunk_steps`` states a call, the last block padded with its last state); None when
        not compiled (the caller maps the robot's ``ee_position``)."""
        native = self._native("ee_flat")
        if native is None:
            return None
        Q = np.asarray(Q, dtype=float)
        N, K = len(Q), self.chunk_steps
        out = np.empty((N, 3))
        block = np.empty((K, self.n))
        for start in range(0, N, K):
            rows = Q[start : start + K]
            block[: len(rows)] = rows
            block[len(rows) :] = rows[-1]
            native.x[:] = block.ravel()
            out[start : start + len(rows)] = native().reshape(K, 3)[: len(rows)]
        return out

    def gravity_efforts(self, q: Array) -> Array:
        """Tg at q: the actuator efforts that hold the robot at rest (n_act,), by ``effort``."""
        x = np.concatenate([np.asarray(q, dtype=float), np.zeros(self.n)])
        native = self._native("effort")
        if native is None:
            out: Array = np.asarray(self.effort(x), dtype=float).ravel()[self.n_act :]
            return out
        native.x[:] = x
        native()
        return native.dense().ravel(order="F")[self.n_act :]

    def advance(
        self, q: Array, dq: Array, u: float, s: float, ext: Array, p: Array, dt: float
    ) -> tuple[Array, Array]:
        """``step``: (q, dq) after dt with u, s, ext held."""
        x = np.concatenate([q, dq, [u, s], ext, p, [dt]])
        v = self.step_flat(x).full().ravel()
        return v[: self.n], v[self.n :]

    def run_chunk(
        self, q: Array, dq: Array, u: float, s: float, ext: Array, p: Array, dt: float,
        ahead: int = 0, stop_error: float = -np.inf,
    ) -> tuple[Array, Array]:
        """``chunk_steps`` steps from (q, dq): states after each step (K, 2n) and the records
        (K, n + n_act + 2) = [ddq, tau, err, f] at each step's start
        (:mod:`~mmplan.planners.extended_jacobian.step`).

        ``ahead``: chunks that may run after this one; unless the guesses in flight go on
        already, start them (the next from this one's last state, the same u, s, ext, p, dt)
        on a second core now (compiled only; :mod:`~mmplan.planners.extended_jacobian.
        prefetch`): a later call with exactly that input takes its result. Not after a chunk
        in which a step's task error is below ``stop_error`` (the run ends in it: a guess
        would keep the worker thread busy when the time scaling wants it)."""
        if self.chunk is None:
            raise RuntimeError("no chunk function")
        par = np.concatenate([p, [u, s], ext, [dt]])
        if self.native_chunk is not None:  # ctypes call, no CasADi/DM conversion
            x = np.concatenate([q, dq, par])
            y = self._native_call(x)
            n, K, a = self.n, self.chunk_steps, self.n_act
            X = y[: 2 * n * K].reshape(K, 2 * n)
            R = y[2 * n * K : len(y) - n * n - 2 * a * K].reshape(K, -1)
            if ahead > 0 and not R[:, n + a].min() < stop_error:
                self._guess_after(x, y, ahead, stop_error)
            return X, R
        X, R = self.chunk(np.concatenate([q, dq]), par)
        return np.asarray(X).T, np.asarray(R).T

    def chunk_start_E(self) -> Array | None:
        """E at the first state of the last native ``run_chunk`` call (None otherwise)."""
        if self.native_chunk is None or self._last is None:
            return None
        n, end = self.n, len(self._last) - 2 * self.n_act * self.chunk_steps
        return self._last[end - n * n : end].reshape(n, n, order="F")

    def chunk_effort(self) -> Array | None:
        """[Tm dq, Tg] (K, 2 n_act) at each step's start of the last native ``run_chunk``
        call (None otherwise)."""
        if self.native_chunk is None or self._last is None:
            return None
        a, K = self.n_act, self.chunk_steps
        return self._last[len(self._last) - 2 * a * K :].reshape(K, 2 * a)

    def guess_chunk(
        self, q: Array, p: Array, dt: float, chunks: int = 1, stop_error: float = -np.inf
    ) -> None:
        """Start the compiled chunks a rollout from rest at q (u = s = 1, no push) begins
        with on a second core now, at most ``chunks``, ending after one in which the task
        error falls below ``stop_error`` (:mod:`~mmplan.planners.extended_jacobian.prefetch`):
        the set-up before the rollout's first chunk runs meanwhile, and the rollout takes
        the results."""
        if self.native_chunk is None or chunks < 1:
            return
        n = self.n
        q, p = np.asarray(q, dtype=float), np.asarray(p, dtype=float)
        par = np.concatenate([p, [1.0, 1.0], np.zeros(n), [dt]])  # as run_chunk builds it
        # replace: the previous plan's guesses may be in flight
        self._speculate().guess(np.concatenate([q, np.zeros(n), par]), replace=True,
                                ahead=chunks - 1, stop=stop_error)  # fmt: skip

    def settle_guesses(self) -> None:
        """End the guessed chunks in flight (the rollout is over: the worker thread is the
        time scaling's)."""
        if self.native_chunk is not None:
            self._speculate().settle()

    def _speculate(self) -> Speculation:
        """The native chunk's calls (prefetch.py; kept on the compiled function): each next
        chunk starts from the last one's final state (the rows of ``run_chunk``'s output)."""
        n, K, a = self.n, self.chunk_steps, self.n_act
        follow = threads.Follow(
            src=2 * n * (K - 1), dst=0, len=2 * n, err_at=2 * n * K + n + a, err_step=n + a + 2,
            err_count=K,
        )  # fmt: skip
        return speculation_of(self.native_chunk, follow)

    def _native_call(self, x: Array) -> Array:
        self._last = y = self._speculate().call(x)
        return y

    def _guess_after(self, x: Array, y: Array, ahead: int, stop_error: float) -> None:
        """Start the chunks after the one at x (output y) on a second core, at most
        ``ahead``, unless the guesses in flight go on already."""
        speculation = self._speculate()
        if speculation.pending:
            return
        m = 2 * self.n
        after = np.array(x)
        after[:m] = y[m * (self.chunk_steps - 1) : m * self.chunk_steps]  # last state
        speculation.guess(after, ahead=ahead - 1, stop=stop_error)
