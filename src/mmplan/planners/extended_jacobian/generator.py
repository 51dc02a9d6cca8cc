r"""Compiled generator step of the extended-Jacobian planner ([PajakPajak] eqs. (16)-(24),
[Pajak] eqs. (12)-(18)).

One symbolic model, two CasADi functions (optionally code-generated to C and compiled):

``terms(q, dq, p) -> (f0, fv, fp, S, T0, Tm, err, Tg, gK)`` at one state, with
``p = [p_f (3), Lambda_P, Lambda_V, Lambda_II]``:

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
  superellipsoid): the damping rate of the term -varrho dq K of eq. (19);
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

import casadi as ca
import numpy as np

from mmplan.compile import codegen as cg
from mmplan.planners.extended_jacobian import near_goal as ej_nearpush
from mmplan.planners.extended_jacobian import obstacles as ej_obstacles
from mmplan.planners.extended_jacobian import step as ej_step
from mmplan.planners.extended_jacobian.criterion import Criterion
from mmplan.planners.extended_jacobian.effort import effort_split
from mmplan.planners.extended_jacobian.functions import GeneratorFunctions, LazyFunction
from mmplan.planners.extended_jacobian.obstacles import (
    ObstacleTerm,
    obstacle_functions,
    obstacle_penalty,
)
from mmplan.planners.extended_jacobian.step import (
    StepParts,
    build_chunk,
    build_chunk_flat,
    build_record_step,
    build_record_step_culled,
    reference_step,
    step_wrapper,
)
from mmplan.planners.extended_jacobian.structure import structured_solve
from mmplan.robot.robot import Robot

#: C compiler flags of the generated generator (measured: -O2 about 2x faster than -O1 here,
#: -O3 -ffast-math no faster and 3x slower to compile).
CFLAGS = ("-O2", "-march=native")

#: Source files whose code shapes the compiled library (part of its cache key).
_SOURCES = (__file__, ej_step.__file__, ej_obstacles.__file__, ej_nearpush.__file__)


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
    obstacles: Sequence[ObstacleTerm],
    varrho: float = 1.0,
    arm_weight: float = 0.3,
    codegen: bool = False,
    notify: Callable[[str], None] | None = None,
    cull: bool = True,
) -> GeneratorFunctions:
    """Build ``terms``, ``step``, ``chunk`` and ``E`` for one problem ([PajakPajak] eqs. (16)-(24)).

    With ``codegen`` the flat functions are compiled to C (cached; ``notify`` is told before
    a build that is not cached); with ``cull`` (default) the compiled step evaluates an
    obstacle's terms only when a collision point is near it
    (:mod:`~mmplan.planners.extended_jacobian.obstacles`, exact).
    """
    s = robot.symbols
    n = robot.n
    q, dq = s.q, s.dq
    p = ca.SX.sym("p", 6)
    # Substitute the goal symbol of the criterion by the parameter vector.
    e_I = ca.substitute(crit.e_I, crit.p_f, p[:3])
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
    K = (
        obstacle_penalty(s.collision_points, obstacles, radii=robot.collision_radii)
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
    damp = ca.Function("damp", [q], [S, P])
    E_fn = ca.Function("mmplan_ej_E", [q, p], [E])
    xt = ca.SX.sym("x", 2 * n + 6)
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
    if codegen:
        key_fn = ca.Function("key", [q, dq, p], [f0, fv, fp, S, T0, Tm, err, Tg, gK, P])
        key = "\n".join([key_fn.serialize(), str(cull), *(Path(m).read_text() for m in _SOURCES)])

        def make() -> list[ca.Function]:
            if obstacles and cull:  # obstacle blocks only where a point is near (obstacles.py)
                winv = wheel_metric_inverse(robot)
                finish = ej_nearpush.finish_function(robot, A, q, p, winv)
                ob_terms, ob_damp = obstacle_functions(robot, obstacles, P, G, varrho, finish)
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
            else:
                record_c = build_record_step(parts, accel, damp, cse=True)
            terms_c = ca.Function("mmplan_ej_terms_flat", [xt], ca.cse([terms_flat(xt)]))
            effort_c = ca.Function("mmplan_ej_effort", [xe], ca.cse([effort_expr]))
            chunk_c = build_chunk(record_c)
            flat = build_chunk_flat(chunk_c, E_fn, effort_c)
            return [terms_c, step_wrapper(record_c, n), chunk_c, record_c, effort_c, flat]

        built = cg.compile_library(make, "ej", CFLAGS, notify, key)
        if built is not None:
            names = ["terms_flat", "step_flat", "chunk", "record_step", "effort"]
            terms_flat, step_flat, chunk, record, effort = cg.load(
                [f"mmplan_ej_{x}" for x in names], built
            )
            return GeneratorFunctions(
                None, terms, E_fn, n, n_act, True, terms_flat, step_flat, effort, chunk,
                record=record, native_chunk=cg.NativeFunction(built, "mmplan_ej_chunk_flat"),
            )  # fmt: skip
    # Built on first use (0.1-0.3 s): the loop advances with it only outside compiled chunks.
    reference = functools.cache(functools.partial(reference_step, accel, damp, n, p))

    def reference_part(i: int) -> ca.Function:
        return reference()[i]

    lazy_step, lazy_flat = (LazyFunction(functools.partial(reference_part, i)) for i in (0, 1))
    record = build_record_step(parts, accel, damp)
    chunk = build_chunk(record)
    return GeneratorFunctions(
        lazy_step, terms, E_fn, n, n_act, False, terms_flat, lazy_flat, effort, chunk,
        record=record,
    )  # fmt: skip
