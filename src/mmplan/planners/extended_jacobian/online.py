"""The extended-Jacobian generator as an online step for a control loop.

State in, (ddq, tau, u) out: the generator terms ([PajakPajak] eq. (16) split as
ddq = f0 + u fv, the obstacle perturbation of eq. (19), tau = T0 + Tm ddq of eq. (22)) and
the virtual-control choice of its s.4 (cases (a)-(d), growth law), exactly as in a planned
rollout (:func:`mmplan.planners.extended_jacobian.torque.decision.decide`), in one CasADi call
(:mod:`mmplan.planners.extended_jacobian.torque.decision_symbolic`; compiled to C when the
planner's generator is,
and then called through ctypes, :class:`mmplan.compile.codegen.NativeFunction`).
When that call reports an infeasible choice (eq. (30) violated) the NumPy decision runs
instead, which also picks the least-violating u. The caller integrates the motion (or feeds
ddq and tau to its controller) and calls again with the next measured state.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from mmplan.arrays import Array
from mmplan.compile import codegen as cg
from mmplan.planners.extended_jacobian.generator import GeneratorFunctions
from mmplan.planners.extended_jacobian.options import RolloutOptions
from mmplan.planners.extended_jacobian.torque import feedback as ej_feedback
from mmplan.planners.extended_jacobian.torque.decision import decide


class OnlineGenerator:
    """Online generator step (build it with ``ExtendedJacobian().online(problem)``).

    The virtual control starts at u0 = 0 (u = 1 without torque control) and is carried from
    call to call; the growth law assumes calls ``options.dt`` apart.
    """

    def __init__(
        self,
        fns: GeneratorFunctions,
        p: Array,
        options: RolloutOptions,
        notify: Callable[[str], None] | None = None,
    ) -> None:
        self._fns = fns
        self._p = np.array(p, dtype=float)  # the generator parameters (fns.layout.pack)
        self._opt = options
        self._zero = np.zeros(fns.n)
        self._first = True
        self.u = 0.0 if options.torque_control else 1.0
        self._n, self._a = fns.n, fns.n_act
        self._call, library = ej_feedback.online_function(fns, options, notify)
        self._native: cg.NativeFunction | None = None
        if library is not None:
            self._native = cg.NativeFunction(library, "mmplan_ej_online")
            self._native.x[2 * fns.n + 2 :] = self._p
        self.compiled = self._native is not None
        self.fallbacks = 0  # samples decided by NumPy (eq. (30) violated)

    def step(self, q: ArrayLike, dq: ArrayLike) -> tuple[Array, Array, float]:
        """(ddq (n,), tau (n_act,), u) at the state (q, dq)."""
        n, a = self._n, self._a
        if self._native is not None:
            x = self._native.x
            x[:n], x[n : 2 * n] = q, dq
            x[2 * n], x[2 * n + 1] = self.u, 1.0 if self._first else 0.0
            v = self._native()
        else:
            x = np.concatenate([q, dq, (self.u, 1.0 if self._first else 0.0), self._p])
            v = self._call(x).full().ravel()
        if v[-1] > 0.5:
            self.u, self._first = float(v[n + a]), False
            return v[:n].copy(), v[n : n + a].copy(), self.u
        self.fallbacks += 1
        dq_arr = np.asarray(dq, dtype=float)
        out = self._fns.evaluate(np.asarray(q, dtype=float), dq_arr, self._p)
        d = decide(out, dq_arr, self.u, self._first, self._zero, self._opt)
        self.u, self._first = d.u, False
        return d.ddq, d.tau, d.u
