"""Functions of the feedback-mode decision, built per problem and options (speed).

:func:`online_function` is the one-call online step of
:mod:`~mmplan.planners.extended_jacobian.torque.decision_symbolic` (compiled to
C and cached when the generator is); :func:`feedback_chunk` runs ``chunk_steps`` rollout
steps with that decision in one call: ``(x0 = [q; dq; u_prev; first], par = [p; dt]) ->
(X, REC)`` with X the states [q; dq; u; 0] after each step and REC the records
[ddq; tau; err; f; u; s; ok] at each step's start (``ok`` = 0: the NumPy decision must
decide that sample, see :mod:`mmplan.planners.extended_jacobian.chunks`). Both are kept in
``fns.cache`` so that repeated plans with the same options build them once.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import casadi as ca

from mmplan.arrays import Array
from mmplan.compile import codegen as cg
from mmplan.planners.extended_jacobian.functions import LazyFunction
from mmplan.planners.extended_jacobian.generator import CFLAGS, PLAIN_CFLAGS, GeneratorFunctions
from mmplan.planners.extended_jacobian.options import RolloutOptions
from mmplan.planners.extended_jacobian.torque import decision_symbolic as ej_decision_sym
from mmplan.planners.extended_jacobian.torque import virtual_control as vc

_Args = tuple[tuple[Array, Array], float, bool, bool, vc.Growth, tuple[float, float, float]]


def _args(opt: RolloutOptions) -> _Args:
    return (
        opt.zone,
        opt.dt,
        opt.torque_control,
        opt.budget_perturbation,
        opt.eps_growth,
        (opt.rho, opt.rho_min, opt.rho_max),
    )


def _terms(fns: GeneratorFunctions, culled: bool = False) -> ca.Function:
    """``terms`` (built now if the generator came from the disk cache); with ``culled`` the
    one with the culled obstacle calls when there is one (for C code: the full obstacle sum
    over every slot made the online step 4x slower)."""
    if "symbolic" in fns.cache:  # loaded from the disk cache (compiled.py)
        fns = fns.cache["symbolic"]()
    if culled and "culled_terms" in fns.cache:
        made: ca.Function = fns.cache["culled_terms"]()
        return made
    fn = fns.terms
    return fn.function if isinstance(fn, LazyFunction) else fn


def online_function(
    fns: GeneratorFunctions, opt: RolloutOptions, notify: Callable[[str], None] | None = None
) -> tuple[ca.Function, str | None]:
    """The online function and the path of its compiled library (None on the VM)."""
    args = _args(opt)
    key = "online" + repr(args)
    if key not in fns.cache:
        fn, library = None, None
        if fns.compiled:
            source = Path(ej_decision_sym.__file__).read_text()
            model = fns.key or fns.terms.serialize()  # the disk key: no model build
            cache_key = "\n".join([model, repr(args), source])

            def make() -> list[ca.Function]:
                return [ej_decision_sym.build_online(_terms(fns, True), fns.n, *args, cse=True)]

            library = cg.compile_library(
                make, "ej_online", CFLAGS, notify, cache_key, fallback=PLAIN_CFLAGS
            )
            if library is not None:
                fn = cg.load(["mmplan_ej_online"], library)[0]
        if fn is None:
            fn = ej_decision_sym.build_online(_terms(fns), fns.n, *args)
        fns.cache[key] = (fn, library)
    fn, library = fns.cache[key]
    return fn, library


def feedback_chunk(fns: GeneratorFunctions, opt: RolloutOptions) -> ca.Function | None:
    """The feedback-mode chunk (module docstring), None without a fused step."""
    if fns.record is None:
        return None
    key = "chunk" + repr(_args(opt))
    if key not in fns.cache:
        online, _ = online_function(fns, opt)
        n, a, k = fns.n, fns.n_act, fns.layout.size
        x = ca.MX.sym("x", 2 * n + 2)
        par = ca.MX.sym("par", k + 1)
        d = online(ca.vertcat(x, par[:k]))
        u, s, ok = d[n + a], d[n + a + 1], d[n + a + 2]
        x_next, rec = fns.record(x[: 2 * n], ca.vertcat(par[:k], u, s, ca.MX.zeros(n), par[k]))
        step = ca.Function(
            "mmplan_ej_feedback_step",
            [x, par],
            [ca.vertcat(x_next, u, 0.0), ca.vertcat(rec, u, s, ok)],
        )
        steps = fns.chunk_steps
        acc = step.mapaccum("mmplan_ej_feedback_acc", steps)
        x0, p0 = ca.MX.sym("x0", 2 * n + 2), ca.MX.sym("p0", k + 1)
        X, R = acc(x0, ca.repmat(p0, 1, steps))
        fns.cache[key] = ca.Function("mmplan_ej_feedback_chunk", [x0, p0], [X, R])
    chunk: ca.Function = fns.cache[key]
    return chunk
