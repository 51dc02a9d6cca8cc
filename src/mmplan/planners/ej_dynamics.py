r"""Compiled generator step of the extended-Jacobian planner (000 eqs. (16)-(24), 003 (12)-(18)).

One symbolic model, two CasADi functions (optionally code-generated to C and compiled):

``terms(q, dq, p) -> (f0, fv, fp, S, T0, Tm, err, Tg, gK)`` at one state, with
``p = [p_f (3), Lambda_P, Lambda_V, Lambda_II]``:

* f0 = -E^-1 v1 and fv = -E^-1 v2 (eq. (16) of 000 split so that eq. (23) reads
  ddq = f0 + u fv + ...), computed with directional derivatives (jtimes), which keeps the
  expression about 5x smaller than differentiating de_I/dq as a matrix;
* fp = P (-varrho G grad K): the obstacle push of eq. (19) projected into ker A with the
  wheel-metric projector P = I - W^-1 A^T (A W^-1 A^T)^-1 A, W^-1 = diag(1, .., 1/r^2 at the
  wheel angles, .., 1) (SPEC pitfall: the Euclidean A^+ A shrinks the push ~800x); G weights
  the gradient (1 on platform coordinates, ``arm_weight`` on arm joints);
* S = varrho K, K = sum over collision points and obstacles of
  kappa_o = ((delta - C)/C)^2 for C < delta (C the radial distance to the enlarged
  superellipsoid): the damping rate of the term -varrho dq K of eq. (19);
* T0, Tm: tau = T0 + Tm ddq (eq. (22) of 000), so that tau(u) = a u + b of eq. (24) has
  a = Tm fv and b = T0 + Tm f0 + s Tm (fp - S dq) (s: perturbation budget, 1 without limits);
* err = |k(q) - p_f|; Tg: the gravity part of T0 (T0 at dq = 0); gK = dK/dq (n,).

``step(q, dq, u, s, ext, p, dt) -> (q+, dq+)``: one step of dt. The damping -s S(q) dq is
integrated exactly, dq *= exp(-s S dt / 2), before and after one RK4 step of
ddq = f0 + u fv + s fp + P ext (Strang splitting, SPEC "Stiffness"); u, s, ext are held.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import casadi as ca
import numpy as np
from numpy.typing import NDArray

from mmplan.planners.ej_criterion import Criterion
from mmplan.robot.robot import Robot

Array = NDArray[np.float64]

#: C compiler flags of the generated generator (measured: -O2 about 2x faster than -O1 here,
#: -O3 -ffast-math no faster and 3x slower to compile).
CFLAGS = ("-O2", "-march=native")


class SmoothObstacle(Protocol):
    """What the generator needs of an obstacle model (a scene ``Superellipsoid``)."""

    def radial_distance_sym(self, p: ca.SX) -> ca.SX:
        """Radial distance C from the point p (3,) to the surface, SX scalar."""
        ...


@dataclass(frozen=True)
class ObstacleTerm:
    """One obstacle for the perturbation: its smooth (already enlarged) model and delta [m]."""

    model: SmoothObstacle
    influence: float


def wheel_metric_inverse(robot: Robot) -> np.ndarray:
    """Diagonal of W^-1: 1/r^2 at wheel-angle coordinates (rolled distance metric), else 1."""
    diag = np.ones(robot.n)
    radius = getattr(robot.platform, "wheel_radius", None)
    if radius is not None:
        for i in range(3, robot.n_platform):
            diag[i] = 1.0 / radius**2
    return diag


def obstacle_penalty(
    points: ca.SX, obstacles: Sequence[ObstacleTerm], c_floor: float = 1e-3
) -> ca.SX:
    """K = sum_{o, points} kappa_o(C) with kappa_o = ((delta - C)/C)^2 for C < delta, else 0.

    Args:
        points: Collision points (3, P).
        obstacles: Obstacles with their neighbourhood delta.
        c_floor: C is clamped below at this value [m] (the barrier is then ~(delta/c_floor)^2).
    """
    total = ca.SX(0)
    for ob in obstacles:
        for j in range(points.shape[1]):
            C = ca.fmax(ob.model.radial_distance_sym(points[:, j]), c_floor)
            kappa = ((ob.influence - C) / C) ** 2
            total += ca.if_else(ob.influence > C, kappa, 0.0)
    return total


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


@dataclass
class GeneratorFunctions:
    """The generator functions and their sizes (see the module docstring).

    ``terms`` and ``step`` are the SX reference functions; ``terms_flat`` (x = [q; dq; p])
    and ``step_flat`` (x = [q; dq; u; s; ext; p; dt]) compute the same with one input and
    one output each (one NumPy conversion a call), compiled to C when ``compiled``.
    """

    terms: ca.Function
    step: ca.Function
    E: ca.Function
    n: int
    n_act: int
    compiled: bool
    terms_flat: ca.Function
    step_flat: ca.Function

    def evaluate(self, q: Array, dq: Array, p: Array) -> Terms:
        """``terms`` at (q, dq) with parameters p = [p_f, Lambda_P, Lambda_V, Lambda_II]."""
        v = self.terms_flat(np.concatenate([q, dq, p])).full().ravel()
        n, a = self.n, self.n_act
        cut = np.cumsum([n, n, n, 1, a, a * n, 1, a])
        f0, fv, fp, S, T0, Tm, err, Tg, gK = np.split(v, cut)
        return Terms(f0, fv, fp, float(S[0]), T0, Tm.reshape(n, a).T, float(err[0]), Tg, gK)

    def advance(
        self, q: Array, dq: Array, u: float, s: float, ext: Array, p: Array, dt: float
    ) -> tuple[Array, Array]:
        """``step``: (q, dq) after dt with u, s, ext held."""
        x = np.concatenate([q, dq, [u, s], ext, p, [dt]])
        v = self.step_flat(x).full().ravel()
        return v[: self.n], v[self.n :]


def build_functions(
    robot: Robot,
    crit: Criterion,
    obstacles: Sequence[ObstacleTerm],
    varrho: float = 1.0,
    arm_weight: float = 0.3,
    codegen: bool = False,
) -> GeneratorFunctions:
    """Build ``terms``, ``step`` and ``E`` for one problem (eqs. (16)-(24) of 000)."""
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
    rhs = ca.solve(E, ca.horzcat(v1, v2))
    f0, fv = -rhs[:, 0], -rhs[:, 1]
    # Wheel-metric null-space projector.
    Winv = ca.diag(ca.DM(wheel_metric_inverse(robot)))
    P = ca.SX.eye(n) - Winv @ A.T @ ca.solve(A @ Winv @ A.T, A)
    K = obstacle_penalty(s.collision_points, obstacles) if obstacles else ca.SX(0)
    G = np.ones(n)
    G[list(robot.arm_indices)] = arm_weight
    gK = ca.gradient(K, q)
    fp = P @ (-varrho * (ca.DM(G) * gK))
    S = varrho * K
    T0, Tm = _effort_split(robot)
    Tg = ca.solve(
        s.null_basis.T @ s.actuation, s.null_basis.T @ ca.substitute(s.bias, dq, ca.SX.zeros(n))
    )
    err = ca.norm_2(s.ee_position - p[:3])
    terms = ca.Function(
        "mmplan_ej_terms",
        [q, dq, p],
        [f0, fv, fp, S, T0, Tm, err, Tg, gK],
        ["q", "dq", "p"],
        ["f0", "fv", "fp", "S", "T0", "Tm", "err", "Tg", "gK"],
    )
    # One step: Strang splitting of the damping around RK4 of the rest.
    u, sp, dt = ca.SX.sym("u"), ca.SX.sym("s"), ca.SX.sym("dt")
    ext = ca.SX.sym("ext", n)
    accel = ca.Function("acc", [q, dq, u, sp, ext, p], [f0 + u * fv + sp * fp + P @ ext])
    damp = ca.Function("damp", [q], [S])
    qs, dqs = ca.SX.sym("q", n), ca.SX.sym("dq", n)
    d1 = dqs * ca.exp(-sp * damp(qs) * dt / 2)
    k1v = d1
    k1a = accel(qs, d1, u, sp, ext, p)
    k2v = d1 + dt / 2 * k1a
    k2a = accel(qs + dt / 2 * k1v, k2v, u, sp, ext, p)
    k3v = d1 + dt / 2 * k2a
    k3a = accel(qs + dt / 2 * k2v, k3v, u, sp, ext, p)
    k4v = d1 + dt * k3a
    k4a = accel(qs + dt * k3v, k4v, u, sp, ext, p)
    q_next = qs + dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
    dq_next = d1 + dt / 6 * (k1a + 2 * k2a + 2 * k3a + k4a)
    dq_next = dq_next * ca.exp(-sp * damp(q_next) * dt / 2)
    step = ca.Function(
        "mmplan_ej_step",
        [qs, dqs, u, sp, ext, p, dt],
        [q_next, dq_next],
        ["q", "dq", "u", "s", "ext", "p", "dt"],
        ["q_next", "dq_next"],
    )
    step = step.expand()
    E_fn = ca.Function("mmplan_ej_E", [q, p], [E])
    xt = ca.SX.sym("x", 2 * n + 6)
    outs = terms(xt[:n], xt[n : 2 * n], xt[2 * n :])
    terms_flat = ca.Function("mmplan_ej_terms_flat", [xt], [ca.vertcat(*[ca.vec(o) for o in outs])])
    xs = ca.SX.sym("x", 3 * n + 9)
    nxt = step(
        xs[:n],
        xs[n : 2 * n],
        xs[2 * n],
        xs[2 * n + 1],
        xs[2 * n + 2 : 3 * n + 2],
        xs[3 * n + 2 : 3 * n + 8],
        xs[3 * n + 8],
    )
    step_flat = ca.Function("mmplan_ej_step_flat", [xs], [ca.vertcat(*nxt)])
    compiled = False
    if codegen:
        built = _compile([terms_flat, step_flat])
        if built is not None:
            terms_flat = ca.external("mmplan_ej_terms_flat", built)
            step_flat = ca.external("mmplan_ej_step_flat", built)
            compiled = True
    return GeneratorFunctions(
        terms, step, E_fn, n, len(robot.actuators), compiled, terms_flat, step_flat
    )


def _effort_split(robot: Robot) -> tuple[ca.SX, ca.SX]:
    """T0 (n_act,) and Tm (n_act, n) with tau = T0 + Tm ddq (eq. (22) of 000).

    Without friction c(q, dq) = C(q, dq) dq + g(q) is rebuilt from M as
    d/dt(M) dq - 1/2 d(dq^T M dq)/dq + g(q) (Lagrange), about half the expression size of the
    robot's bias; with friction the robot's bias is used as is.
    """
    s = robot.symbols
    q, dq = s.q, s.dq
    NB = s.null_basis.T @ s.actuation  # (n_act, n_act)
    if robot.friction:
        bias = s.bias
    else:
        M = s.mass_matrix
        gravity = ca.substitute(s.bias, dq, ca.SX.zeros(robot.n))
        bias = ca.jtimes(M @ dq, q, dq) - 0.5 * ca.gradient(dq.T @ M @ dq, q) + gravity
    T0 = ca.solve(NB, s.null_basis.T @ bias)
    Tm = ca.solve(NB, s.null_basis.T @ s.mass_matrix)
    return T0, Tm


def _compile(functions: Sequence[ca.Function]) -> str | None:
    """Generate C for ``functions``, compile it with the system C compiler (cached by source hash).

    Returns the shared-library path, or None when no compiler is available.
    """
    compiler = shutil.which("gcc") or shutil.which("cc")
    if compiler is None:
        return None
    gen = ca.CodeGenerator("mmplan_ej.c", {"with_header": False})
    for f in functions:
        gen.add(f)
    source = gen.dump()
    digest = hashlib.sha1((" ".join(CFLAGS) + source).encode()).hexdigest()[:16]
    cache = Path(os.environ.get("MMPLAN_CACHE", Path(tempfile.gettempdir()) / "mmplan-codegen"))
    cache.mkdir(parents=True, exist_ok=True)
    lib = cache / f"ej_{digest}.so"
    if not lib.exists():
        src = cache / f"ej_{digest}.c"
        src.write_text(source)
        tmp = cache / f"ej_{digest}.{os.getpid()}.so"
        result = subprocess.run(
            [compiler, *CFLAGS, "-shared", "-fPIC", str(src), "-o", str(tmp), "-lm"],
            capture_output=True,
            text=True,
            check=False,
        )
        if result.returncode != 0:
            return None
        tmp.replace(lib)
    return str(lib)
