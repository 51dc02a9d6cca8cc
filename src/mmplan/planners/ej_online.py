"""The extended-Jacobian generator as an online step for a control loop.

State in, (ddq, tau, u) out: one compiled ``terms`` evaluation (eq. (16) of 000 split as
ddq = f0 + u fv, the obstacle perturbation of eq. (19), tau = T0 + Tm ddq of eq. (22)) and
the virtual-control choice of section 4 (cases (a)-(d), growth law), exactly as in a planned
rollout (:func:`mmplan.planners.ej_decision.decide`). The caller integrates the motion (or
feeds ddq and tau to its controller) and calls again with the next measured state.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mmplan.planners.ej_decision import decide
from mmplan.planners.ej_dynamics import GeneratorFunctions
from mmplan.planners.ej_rollout import RolloutOptions

Array = NDArray[np.float64]


class OnlineGenerator:
    """Online generator step (build it with ``ExtendedJacobian().online(problem)``).

    The virtual control starts at u0 = 0 (u = 1 without torque control) and is carried from
    call to call; the growth law assumes calls ``options.dt`` apart.
    """

    def __init__(self, fns: GeneratorFunctions, p_f: Array, options: RolloutOptions) -> None:
        self._fns = fns
        self._p = np.concatenate([np.asarray(p_f, dtype=float), options.gains])
        self._opt = options
        self._zero = np.zeros(fns.n)
        self._first = True
        self.u = 0.0 if options.torque_control else 1.0

    def step(self, q: ArrayLike, dq: ArrayLike) -> tuple[Array, Array, float]:
        """(ddq (n,), tau (n_act,), u) at the state (q, dq)."""
        dq_arr = np.asarray(dq, dtype=float)
        out = self._fns.evaluate(np.asarray(q, dtype=float), dq_arr, self._p)
        d = decide(out, dq_arr, self.u, self._first, self._zero, self._opt)
        self.u, self._first = d.u, False
        return d.ddq, d.tau, d.u
