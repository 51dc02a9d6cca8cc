"""Samples of an extended-Jacobian rollout, stored as blocks (speed).

The rollout records one sample per step (t, q, dq, ddq, tau, u, s and the task error); a
compiled chunk (:mod:`~mmplan.planners.extended_jacobian.chunks`) delivers many at once. Appending
each chunk as one block and concatenating at the end costs one NumPy call per chunk and key, where a
list of rows cost one Python object per sample and key (measured on youbot3r-obstacles-torque at
dt = 20 ms: about 1.5 ms of a 15 ms plan). The task error is also kept in a flat array, as the stall
verdict looks it up by sample index.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from mmplan.arrays import Array

KEYS = ("t", "q", "dq", "ddq", "tau", "u", "s", "err")
#: Optional keys: [Tm dq, Tg] of the effort split at each sample (time mode, time_scaling.py).
EFFORT = "effort"


class SampleLog:
    """Blocks of samples; ``err`` by index (:meth:`error`)."""

    def __init__(self, capacity: int) -> None:
        self._blocks: dict[str, list[Array]] = {k: [] for k in (*KEYS, EFFORT)}
        self._effort_complete = True
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
        effort: ArrayLike | None = None,
    ) -> None:
        """Append m samples: t, u, s, err (m,); q, dq, ddq (m, n); tau (m, n_act); effort
        (m, 2 n_act) when known (else the log has no effort array)."""
        m = len(np.atleast_1d(t))
        for key, value in zip(KEYS, (t, q, dq, ddq, tau, u, s, err), strict=True):
            self._blocks[key].append(np.array(value, dtype=float, copy=True))
        if effort is None:
            self._effort_complete = False
        else:
            self._blocks[EFFORT].append(np.array(effort, dtype=float, copy=True))
        if self.count + m > len(self._err):
            self._err = np.concatenate([self._err, np.empty(max(m, len(self._err)))])
        self._err[self.count : self.count + m] = err
        self.count += m

    def add_one(
        self,
        t: float,
        q: Array,
        dq: Array,
        ddq: Array,
        tau: Array,
        u: float,
        s: float,
        err: float,
        effort: Array | None = None,
    ) -> None:
        """Append one sample."""
        self.add(
            [t], [q], [dq], [ddq], [tau], [u], [s], [err], None if effort is None else [effort]
        )

    def error(self, start: int, stop: int) -> Array:
        """Task errors of samples start .. stop - 1 (a view)."""
        return self._err[start:stop]

    def arrays(self) -> dict[str, Array]:
        """Every key as one array (samples along axis 0); ``effort`` only when every sample
        has it."""
        keys = [*KEYS, EFFORT] if self._effort_complete and self._blocks[EFFORT] else KEYS
        return {k: np.concatenate(self._blocks[k], axis=0) for k in keys}
