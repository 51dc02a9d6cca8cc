"""Samples of an extended-Jacobian rollout, stored as blocks (speed).

The rollout records one sample per step (t, q, dq, ddq, tau, u, s and the task error); a
compiled chunk (:mod:`ej_fastpath`) delivers many at once. Appending each chunk as one block
and concatenating at the end costs one NumPy call per chunk and key, where a list of rows
cost one Python object per sample and key (measured on youbot3r-obstacles-torque at
dt = 20 ms: about 1.5 ms of a 15 ms plan). The task error is also kept in a flat array, as
the stall verdict looks it up by sample index.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]

KEYS = ("t", "q", "dq", "ddq", "tau", "u", "s", "err")


class SampleLog:
    """Blocks of samples; ``err`` by index (:meth:`error`)."""

    def __init__(self, capacity: int) -> None:
        self._blocks: dict[str, list[Array]] = {k: [] for k in KEYS}
        self._err = np.empty(max(capacity, 1))
        self.count = 0

    def __len__(self) -> int:
        return self.count

    def add(
        self,
        t: ArrayLike,
        q: ArrayLike,
        dq: ArrayLike,
        ddq: ArrayLike,
        tau: ArrayLike,
        u: ArrayLike,
        s: ArrayLike,
        err: ArrayLike,
    ) -> None:
        """Append m samples: t, u, s, err (m,); q, dq, ddq (m, n); tau (m, n_act)."""
        m = len(np.atleast_1d(t))
        for key, value in zip(KEYS, (t, q, dq, ddq, tau, u, s, err), strict=True):
            self._blocks[key].append(np.array(value, dtype=float, copy=True))
        if self.count + m > len(self._err):
            self._err = np.concatenate([self._err, np.empty(max(m, len(self._err)))])
        self._err[self.count : self.count + m] = err
        self.count += m

    def add_one(
        self, t: float, q: Array, dq: Array, ddq: Array, tau: Array, u: float, s: float, err: float
    ) -> None:
        """Append one sample."""
        self.add([t], [q], [dq], [ddq], [tau], [u], [s], [err])

    def error(self, start: int, stop: int) -> Array:
        """Task errors of samples start .. stop - 1 (a view)."""
        return self._err[start:stop]

    def arrays(self) -> dict[str, Array]:
        """Every key as one array (samples along axis 0)."""
        return {k: np.concatenate(v, axis=0) for k, v in self._blocks.items()}
