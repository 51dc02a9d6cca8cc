r"""Compiled generator step of the extended-Jacobian planner ([PajakPajak] eqs. (16)-(24),
[Pajak] eqs. (12)-(18)).

One symbolic model, two CasADi functions (optionally code-generated to C and compiled):

``terms(q, dq, p) -> (f0, fv, fp, S, T0, Tm, err, Tg, gK)`` at one state, with
``p = [p_f (3), Lambda_P, Lambda_V, Lambda_II, floor, obstacle slots, ...]`` (the scene as
numbers, :mod:`~mmplan.planners.extended_jacobian.parameters`: one function per robot model
and set of obstacle shape types):

* f0 = -E^-1 v1 and fv = -E^-1 v2 ([PajakPajak] eq. (16) split so that eq. (23) reads
  ddq = f0 + u fv + ...), computed with directional derivatives (jtimes), which keeps the
  expression about 5x smaller than differentiating de_I/dq as a matrix;
* fp = P (-varrho G grad K): the obstacle push of eq. (19) projected into ker A with the
  wheel-metric projector P = I - W^-1 A^T (A W^-1 A^T)^-1 A, W^-1 = diag(1, .., 1/r^2 at the
  wheel angles, .., 1) (docs/extended_jacobian.md: the Euclidean A^+ A shrinks the push
  ~800x); G weights
  the gradient (1 on platform coordinates, ``arm_weight`` on arm joints); near the goal its
  end-effector part fades out (:mod:`mmplan.planners.extended_jacobian.near_goal`);
* S = varrho K, K = sum over collision points and obstacles of
  kappa_o = ((delta - C)/C)^2 for C < delta (C the radial distance to the enlarged
  superellipsoid, or the height above the floor: :mod:`~mmplan.planners.extended_jacobian.slots`):
  the damping rate of the term -varrho dq K of eq. (19);
* T0, Tm: tau = T0 + Tm ddq ([PajakPajak] eq. (22)), so that tau(u) = a u + b of eq. (24) has
  a = Tm fv and b = T0 + Tm f0 + s Tm (fp - S dq) (s: perturbation budget, 1 without limits);
* err = |k(q) - p_f|; Tg: the gravity part of T0 (T0 at dq = 0); gK = dK/dq (n,).

``step(q, dq, u, s, ext, p, dt) -> (q+, dq+)`` (:mod:`mmplan.planners.extended_jacobian.step`): one
step of
dt. The damping -s S(q) dq is integrated exactly, dq *= exp(-s S dt / 2), before and after
one RK4 step of
ddq = f0 + u fv + s fp + P ext (Strang splitting, docs/extended_jacobian.md), then dq is projected
into ker A(q+) (constraint stabilization, :mod:`~mmplan.planners.extended_jacobian.step`); u, s, ext
are held.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from mmplan.compile import codegen as cg
from mmplan.planners.extended_jacobian import compiled as ej_compiled
from mmplan.planners.extended_jacobian import near_goal as ej_nearpush
from mmplan.planners.extended_jacobian import obstacles as ej_obstacles
from mmplan.planners.extended_jacobian import parameters as ej_parameters
from mmplan.planners.extended_jacobian import slots as ej_slots
from mmplan.planners.extended_jacobian import step as ej_step
from mmplan.planners.extended_jacobian.compiled import CFLAGS, COLD, PLAIN_CFLAGS
from mmplan.planners.extended_jacobian.criterion import Criterion
from mmplan.planners.extended_jacobian.effort import effort_split
from mmplan.planners.extended_jacobian.functions import GeneratorFunctions, LazyFunction
from mmplan.planners.extended_jacobian.obstacles import ObstacleTerm, obstacle_functions
from mmplan.planners.extended_jacobian.parameters import Shape, layout_of
from mmplan.planners.extended_jacobian.slots import slot_penalty, slot_terms
from mmplan.planners.extended_jacobian.step import (
    StepParts,
    build_chunk,
    build_chunk_flat,
    build_ee_flat,
    build_record_step,
    build_record_step_culled,
    reference_step,
    step_wrapper,
)
from mmplan.planners.extended_jacobian.structure import structured_solve
from mmplan.robot.robot import Robot

#: ``codegen: null`` compiles a generator whose f0, fv (without the obstacle terms, whose
#: compiled code is culled and shared between slots) take at most this many operations: a
#: larger one (a user's robot with many more joints) runs on the virtual machine unless
#: ``codegen: true``. Measured (2026-11-25, 2-core machine, `mmplan plan` on an empty cache):
#: youbot-3r 2.4k operations, compiled in 2.6 s; ur5-omni 7.6k, 9.0 s; TIAGo 25.6k, 17-30 s
#: (163 s in session 8, before the build was cut into units compiled in parallel with the
#: rarely called code at -O0); TIAGo's plan then computes in 0.022 s against 1.01 s on the
#: virtual machine (tiago-table), the UR5's in 0.025 against 0.50 s.
AUTO_SIZE = 30_000

#: Source files whose code shapes the compiled library (part of its cache key).
_SOURCES = (
    __file__,
    ej_step.__file__,
    ej_obstacles.__file__,
    ej_nearpush.__file__,
    ej_parameters.__file__,
    ej_slots.__file__,
)


def wheel_metric_inverse(robot: Robot) -> np.ndarray:
    """Diagonal of W^-1: 1/r^2 at wheel-angle coordinates (rolled distance metric), else 1."""
    diag = np.ones(robot.n)
    radius = getattr(robot.platform, "wheel_radius", None)
    if radius is not None:
        for i in range(3, robot.n_platform):
            diag[i] = 1.0 / radius**2
    return diag


def build_functions(
    robot: Robot,
    crit: Criterion,
    slots: Sequence[tuple[Shape, int]] | Sequence[ObstacleTerm],
    varrho: float = 1.0,
    arm_weight: float = 0.3,
    codegen: bool = False,
    notify: Callable[[str], None] | None = None,
    cull: bool = True,
    disk_key: str | None = None,
    max_size: int | None = None,
) -> GeneratorFunctions:
    """Build ``terms``, ``step``, ``chunk`` and ``E`` of a robot ([PajakPajak] eqs. (16)-(24)).

    ``slots``: the obstacle slots per shape type (or obstacles: their shape types, counts
    rounded up, :func:`~mmplan.planners.extended_jacobian.parameters.slots_for`); the floor
    is always there (off by its parameter). Scenes go in as p (``fns.layout.pack``).

    With ``codegen`` the flat functions are compiled to C (cached; ``notify`` is told before
    a build that is not cached); with ``cull`` (default) the compiled step evaluates an
    obstacle's terms only when a collision point is near it
    (:mod:`~mmplan.planners.extended_jacobian.obstacles`, exact). ``disk_key``
    (:func:`~mmplan.planners.extended_jacobian.compiled.disk_key`) files the library so that
    later runs load it without this build (default: keyed by the model's expressions).
    ``max_size``: compile only when ``terms`` has at most this many operations (else the
    virtual machine, with a ``notify``).
    """
    s = robot.symbols
    n = robot.n
    q, dq = s.q, s.dq
    layout = layout_of(robot, crit, slots)
    p = ca.SX.sym("p", layout.size)
    # Substitute the goal (and partition, heading) symbols of the criterion by parts of p.
    symbols = ca.vertcat(crit.p_f, crit.theta, crit.sel)
    values = ca.vertcat(
        p[:3],
        p[layout.heading_index : layout.heading_index + crit.theta.numel()],
        p[layout.select_index :],
    )
    e_I = ca.substitute(crit.e_I, symbols, values)
    de_I = ca.jtimes(e_I, q, dq)
    dde_I = ca.jtimes(de_I, q, dq)
    A = s.pfaffian
    e_II = A @ dq
    de_II = ca.jtimes(e_II, q, dq)
    E = ca.vertcat(ca.jacobian(e_I, q), A)  # (n, n)
    v1 = ca.vertcat(dde_I, de_II)
    v2 = ca.vertcat(p[4] * de_I + p[3] * e_I, p[5] * e_II)
    solve = functools.partial(structured_solve, robot)  # through ker A (5x5 for youbot-3r)
    rhs = solve(E, ca.horzcat(v1, v2))
    f0, fv = -rhs[:, 0], -rhs[:, 1]
    # Wheel-metric null-space projector.
    Winv = ca.diag(ca.DM(wheel_metric_inverse(robot)))
    P = ca.SX.eye(n) - Winv @ A.T @ ca.solve(A @ Winv @ A.T, A)
    obstacles = slot_terms(robot, layout)
    K = (
        slot_penalty(s.collision_points, robot.collision_radii, obstacles, p)
        if obstacles
        else ca.SX(0)
    )
    G = np.ones(n)
    G[list(robot.arm_indices)] = arm_weight
    gK = ca.gradient(K, q)
    err = ca.norm_2(s.ee_position - p[:3])

    def applied(fp_raw: ca.SX, K: ca.SX) -> ca.SX:
        """The push as applied: near the goal without its end-effector part, arm parts fading
        towards joint limits (:mod:`mmplan.planners.extended_jacobian.near_goal`)."""
        if not obstacles:
            return fp_raw
        out = ej_nearpush.project_push(
            fp_raw, s.jacobian, A, wheel_metric_inverse(robot), ej_nearpush.fade(err, K)
        )
        return ej_nearpush.fade_at_limits(
            out, q, list(robot.arm_indices), robot.limits.joint_min, robot.limits.joint_max
        )

    fp = applied(P @ (-varrho * (ca.DM(G) * gK)), K)
    S = varrho * K
    T0, Tm = effort_split(robot)
    Tg = ca.solve(
        s.null_basis.T @ s.actuation, s.null_basis.T @ ca.substitute(s.bias, dq, ca.SX.zeros(n))
    )
    terms = ca.Function(
        "mmplan_ej_terms",
        [q, dq, p],
        [f0, fv, fp, S, T0, Tm, err, Tg, gK],
        ["q", "dq", "p"],
        ["f0", "fv", "fp", "S", "T0", "Tm", "err", "Tg", "gK"],
    )
    # Stage acceleration and damping rate of the Strang-split RK4 step (step.py).
    u, sp = ca.SX.sym("u"), ca.SX.sym("s")
    ext = ca.SX.sym("ext", n)
    accel = ca.Function("acc", [q, dq, u, sp, ext, p], [f0 + u * fv + sp * fp + P @ ext])
    damp = ca.Function("damp", [q, p], [S, P])
    E_fn = ca.Function("mmplan_ej_E", [q, p], [E])
    xt = ca.SX.sym("x", 2 * n + layout.size)
    outs = terms(xt[:n], xt[n : 2 * n], xt[2 * n :])
    terms_flat = ca.Function("mmplan_ej_terms_flat", [xt], [ca.vertcat(*[ca.vec(o) for o in outs])])
    h, n_act = A.shape[0], len(robot.actuators)
    xe, effort_expr = ca.vertcat(q, dq), ca.vertcat(Tm @ dq, Tg)
    effort = ca.Function("mmplan_ej_effort", [xe], [effort_expr])
    parts = StepParts(
        q, dq, p, E, v1,
        ca.vertcat(p[4] * de_I, p[5] * e_II),
        ca.vertcat(p[3] * e_I, ca.SX.zeros(h)),
        fp, S, P, T0, Tm, err, solve,
    )  # fmt: skip
    size = ca.Function("size", [q, dq, p], [f0, fv]).n_instructions() if max_size else 0
    if codegen and max_size is not None and size > max_size:
        if notify is not None:
            notify(
                f"the generator of {robot.name} is large ({size} operations): it runs on "
                "CasADi's virtual machine (codegen: true under planner: in the scenario "
                "compiles it once, for minutes)"
            )
        codegen = False

    def make_culled() -> tuple[ca.Function, ca.Function, ca.Function]:
        """``terms`` with the culled obstacle calls (obstacles.py), and those calls."""
        finish = ej_nearpush.finish_function(robot, A, q, p, wheel_metric_inverse(robot))
        ob_terms, ob_damp = obstacle_functions(robot, obstacles, layout.size, P, G, varrho, finish)
        base = ca.Function(
            "mmplan_ej_terms_base", [q, dq, p], ca.cse([f0, fv, T0, Tm, err, Tg])
        )
        qm, dqm, pm = ca.MX.sym("q", n), ca.MX.sym("dq", n), ca.MX.sym("p", layout.size)
        S_m, fp_m, gK_m = ob_terms(qm, pm)
        f0_m, fv_m, T0_m, Tm_m, err_m, Tg_m = base(qm, dqm, pm)
        outs = [f0_m, fv_m, fp_m, S_m, T0_m, Tm_m, err_m, Tg_m, gK_m]
        return ca.Function("mmplan_ej_terms_culled", [qm, dqm, pm], outs), ob_terms, ob_damp

    culled_fns = functools.cache(make_culled)

    later: dict[str, Any] = {}
    if layout.n_slots and cull:  # the online step's terms (torque/feedback.py); the floor
        # alone is cheaper inline (measured: youbot-4r online step 20 % slower culled)
        later["culled_terms"] = lambda: culled_fns()[0]
    if codegen:
        if disk_key is None:
            key_fn = ca.Function("key", [q, dq, p], [f0, fv, fp, S, T0, Tm, err, Tg, gK, P])
            texts = (Path(m).read_text() for m in _SOURCES)
            key = "\n".join([key_fn.serialize(), str(cull), *texts])
        else:
            key = disk_key

        def make() -> list[ca.Function]:
            if obstacles and cull:  # obstacle blocks only where a point is near (obstacles.py)
                terms_m, ob_terms, ob_damp = culled_fns()
                S_sym, fp_sym = ca.SX.sym("S"), ca.SX.sym("fp", n)
                acc_fp = ca.Function(
                    "mmplan_ej_acc",
                    [q, dq, u, sp, ext, p, fp_sym],
                    ca.cse([f0 + u * fv + sp * fp_sym + P @ ext]),
                )
                proj = ca.Function("mmplan_ej_proj", [q], [P])
                culled = replace(parts, S=S_sym, fp=fp_sym)
                record_c = build_record_step_culled(
                    culled, S_sym, fp_sym, acc_fp, ob_terms, ob_damp, proj
                )
                # terms from the same culled blocks (the full sum's code took 2/3 of the build)
                xm = ca.MX.sym("x", xt.numel())
                outs_m = terms_m(xm[:n], xm[n : 2 * n], xm[2 * n :])
                flat_m = ca.vertcat(*[ca.vec(o) for o in outs_m])
                terms_c = ca.Function("mmplan_ej_terms_flat", [xm], [flat_m])
            else:
                record_c = build_record_step(parts, accel, damp, cse=True)
                terms_c = ca.Function("mmplan_ej_terms_flat", [xt], ca.cse([terms_flat(xt)]))
            effort_c = ca.Function("mmplan_ej_effort", [xe], ca.cse([effort_expr]))
            chunk_c = build_chunk(record_c)
            flat = build_chunk_flat(chunk_c, E_fn, effort_c)
            step_c = step_wrapper(record_c, n, layout.size)
            ee_c = build_ee_flat(s.q, s.ee_position)
            return [terms_c, step_c, chunk_c, record_c, effort_c, flat, E_fn, ee_c]

        built = cg.compile_library(make, "ej", CFLAGS, notify, key, COLD, PLAIN_CFLAGS)
        if built is not None:
            terms_flat, step_flat, chunk, record, effort, E_c = cg.load(
                [f"mmplan_ej_{x}" for x in ej_compiled.NAMES], built
            )
            fns = GeneratorFunctions(
                None, terms, E_c, n, n_act, True, terms_flat, step_flat, effort, chunk,
                record=record, native_chunk=cg.NativeFunction(built, "mmplan_ej_chunk_flat"),
                layout=layout, key=disk_key or "", cache=later,
                library=built,
            )  # fmt: skip
            if disk_key is not None:
                ej_compiled.save(disk_key, fns, built)
            return fns
    # Built on first use (0.1-0.3 s): the loop advances with it only outside compiled chunks.
    reference = functools.cache(functools.partial(reference_step, accel, damp, n, p))

    def reference_part(i: int) -> ca.Function:
        return reference()[i]

    lazy_step, lazy_flat = (LazyFunction(functools.partial(reference_part, i)) for i in (0, 1))
    record = build_record_step(parts, accel, damp)
    chunk = build_chunk(record)
    return GeneratorFunctions(
        lazy_step, terms, E_fn, n, n_act, False, terms_flat, lazy_flat, effort, chunk,
        record=record, layout=layout, cache=later,
    )  # fmt: skip
