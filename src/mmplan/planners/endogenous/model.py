r"""Compiled model of the endogenous configuration space planner ([JaniakTchon]).

The platform is driven by truncated Fourier controls ([JaniakTchon] eq. (17))

.. math::  u_i(t) = \sum_{j=0}^{s_i} \lambda_{ij} \varphi_j(t),\quad
           \varphi = (1, \sin\omega t, \cos\omega t, \sin 2\omega t, \cos 2\omega t, \dots),
           \ \omega = 2\pi / T,

so ``u(t) = P(t) lambda``; with T = 1 this is the paper's basis (s.III). The platform moves as
``dq_p = G(q_p) u`` with G the platform block of the robot's kernel basis N(q) (for the
kinematic car exactly [JaniakTchon] eq. (16)). Each state bound ``lb <= q_k <= ub`` (platform or
arm coordinate) adds the extra state of eq. (18),

.. math::  \dot w = r(q_k) + p(q_k - ub, a) + p(-q_k + lb, a),\quad
           p(x, a) = \mathrm{softplus}(a x) / a \ \text{(eq. (2))},\quad
           r(q_k) = \varrho\,(q_k - c)^2,

with c = (lb + ub) / 2 (c = 0 for the paper's symmetric bounds, where r = q_k^2 as printed),
and an extra output y = w(T) with target ``\int_0^T r dt`` (eqs. (10)-(13), (19)); the target
integral is carried as one more state ``v``. The output is
``y_r = (k(q_p(T), x), w(T))``.

The end point map and its Jacobian ([JaniakTchon] eq. (7))
``J = [C(T) \int_0^T \Phi(T,t) B(t) P(t) dt, D(T)]`` come from integrating the state together
with its sensitivity ``S = d(q_p, w)/d(lambda, x)``, ``dS/dt = A(t) S + d f/d(lambda, x)``
(A, B as in [JaniakTchon] s.III), so that ``J = C(T) S(T) + D(T)``. Only the columns of S
that the dynamics depend on are integrated (lambda and the bounded arm joints; the other arm
columns of S stay zero). State and sensitivity are integrated by one fixed-step RK4 scheme
(``steps`` steps on [0, T], basis values at t, t + h/2, t + h precomputed) inside one CasADi
function: an MX function whose rollout is a ``mapaccum`` loop over a small SX step. With
``codegen`` it is compiled to C together with the platform path and its rates, in one library
keyed by the model's description (:meth:`EndogenousModel.disk_key`), so a later process loads
it without building the symbolic model (measured on car-rtr-steer30, three alternated CLI
pairs: 87-93 ms a plan against 99-106 ms when every process built the model and generated its
C to find the library; the same samples to the bit). RK4 applied to the variational
equations is exactly the derivative of the discrete RK4 end point map, which keeps the
theta-iteration consistent with the trajectory it reports.
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from dataclasses import dataclass

import casadi as ca
import numpy as np

from mmplan.arrays import Array
from mmplan.compile import codegen as cg
from mmplan.compile.fingerprint import robot_fingerprint, source_fingerprint
from mmplan.robot.robot import Robot

#: The compiled model's functions, by name in its library.
LIBRARY_FUNCTIONS = ("endogenous_endpoint", "endogenous_platform_path", "endogenous_rates")


@dataclass(frozen=True)
class ResolvedBound:
    """A state bound on coordinate ``index`` of q (robot order): ``lower <= q_k <= upper``."""

    index: int
    lower: float
    upper: float

    @property
    def center(self) -> float:
        """Centre c of the regularizer r = w (q - c)^2."""
        return 0.5 * (self.lower + self.upper)


def plus_function(x: ca.SX, sharpness: float) -> ca.SX:
    """Smooth plus function p(x, a) = x + ln(1 + exp(-a x)) / a ([JaniakTchon] eq. (2)).

    Evaluated as softplus(a x) / a = (max(a x, 0) + log1p(exp(-|a x|))) / a, which does not
    overflow for large |a x|.
    """
    ax = sharpness * x
    return (ca.fmax(ax, 0) + ca.log1p(ca.exp(-ca.fabs(ax)))) / sharpness


class EndogenousModel:
    """Compiled end point map, Jacobian and trajectory of the regularized system
    ([JaniakTchon] eq. (10)).

    Args:
        robot: The mobile manipulator; its platform contributes G(q_p) (kernel basis).
        horizon: Control horizon T [s].
        basis_terms: Number of Fourier terms s_i + 1 per platform control (e.g. (3, 5)).
        steps: RK4 steps on [0, T].
        bounds: State bounds (indices in robot order).
        sharpness: a of the plus function.
        regularizer_weight: varrho of r(q) = varrho (q - c)^2.
        codegen: Compile the model to C (cached: module docstring; without a compiler one
            notice line and the virtual machine); ``backend`` says what runs.
    """

    def __init__(
        self,
        robot: Robot,
        horizon: float,
        basis_terms: Sequence[int],
        steps: int,
        bounds: Sequence[ResolvedBound],
        sharpness: float,
        regularizer_weight: float,
        codegen: bool = False,
    ) -> None:
        self.robot = robot
        self.horizon = float(horizon)
        self.basis_terms = tuple(int(b) for b in basis_terms)
        self.steps = int(steps)
        self.bounds = tuple(bounds)
        self.n_p = robot.n_platform
        self.n_x = robot.n - robot.n_platform
        self.n_u = len(robot.platform.actuators)
        self.n_lambda = sum(self.basis_terms)
        self.n_b = len(self.bounds)
        self.n_par = self.n_lambda + self.n_x
        self.n_out = 3 + self.n_b
        self._sharpness = float(sharpness)
        self._weight = float(regularizer_weight)
        self.backend = "vm"
        self.endpoint: ca.Function
        self.platform_path: ca.Function
        self.rates: ca.Function
        library = self._library() if codegen else None
        try:
            if library is not None:  # loaded without building the symbolic model
                self.endpoint, self.platform_path, self.rates = cg.load(LIBRARY_FUNCTIONS, library)
                self.backend = "c"
        except RuntimeError:  # unreadable (another machine's, damaged): the VM, said once
            cg.notice(f"{library} could not be loaded: the endogenous model runs on CasADi's "
                      "virtual machine")  # fmt: skip
        if self.backend == "vm":
            self._build()
        self._bind()

    def _library(self) -> str | None:
        """The compiled library of this model (end point map, platform path, rates), built on
        its first use and found again by :meth:`disk_key` without building the model; None
        without a compiler (with a notice) or when the build fails."""
        if cg.compiler() is None:
            cg.notice(f"{cg.no_compiler()}: the endogenous model runs on CasADi's virtual machine")
            return None

        def functions() -> list[ca.Function]:
            self._build()
            return [self.endpoint, self.platform_path, self.rates]

        # -O1 compiles in a fraction of the time of -O2 at the same speed here.
        return cg.compile_library(functions, "endogenous", ("-O1",), key=self.disk_key())

    def disk_key(self) -> str:
        """What the compiled model depends on: the robot model, horizon, basis, steps, bounds,
        sharpness, regularizer weight and the code that builds it."""
        parts = [
            robot_fingerprint(self.robot),
            repr((self.horizon, self.basis_terms, self.steps, self._sharpness, self._weight)),
            repr([(b.index, b.lower, b.upper) for b in self.bounds]),
            source_fingerprint([__file__, cg.__file__]),
        ]
        return hashlib.sha256("\n".join(parts).encode()).hexdigest()[:24]

    def _bind(self) -> None:
        """Bind NumPy arrays to the end point function (CasADi ``Function.buffer``): a call
        then costs about 0.2 us instead of 25 us of argument conversion. Not thread-safe."""
        sizes = (self.n_p, self.n_lambda, self.n_x, 3)
        self._args = [np.zeros(n) for n in sizes]
        self._outs = [np.zeros(self.n_out), np.zeros(self.n_out * self.n_par), np.zeros(self.n_b)]
        self._buffer, self._call = self.endpoint.buffer()
        for i, arr in enumerate(self._args):
            if arr.size:
                # SWIG typemap: the buffer argument carries its size (stubs list two args)
                self._buffer.set_arg(i, memoryview(arr))  # type: ignore[call-arg, arg-type]
        for i, arr in enumerate(self._outs):
            if arr.size:
                self._buffer.set_res(i, memoryview(arr))  # type: ignore[call-arg, arg-type]

    def _endpoint(self, qp0: Array, lam: Array, x: Array, yd: Array) -> tuple[Array, Array, Array]:
        for arr, value in zip(self._args, (qp0, lam, x, yd), strict=True):
            arr[:] = value
        self._call()
        e, J, v = self._outs
        return e.copy(), J.reshape(self.n_par, self.n_out).T.copy(), v.copy()  # J column-major

    # ------------------------------------------------------------------ symbolic pieces
    def control(self, phi: ca.SX, lam: ca.SX) -> ca.SX:
        """u = P(t) lambda ([JaniakTchon] eq. (17)) from the basis values phi
        (max terms,), (n_u,)."""
        out, k = [], 0
        for terms in self.basis_terms:
            out.append(sum(lam[k + j] * phi[j] for j in range(terms)))
            k += terms
        return ca.vertcat(*out)

    def basis_values(self, t: Array, derivative: bool = False) -> Array:
        """phi_j(t) (or d phi_j / dt) for j < max(basis_terms) at times t (N,), (max terms, N).

        phi = (1, sin wt, cos wt, sin 2wt, cos 2wt, ...), w = 2 pi / T ([JaniakTchon] eq. (17)).
        """
        t = np.asarray(t, dtype=np.float64)
        omega = 2 * np.pi / self.horizon
        rows = [np.zeros_like(t) if derivative else np.ones_like(t)]
        for j in range(1, max(self.basis_terms)):
            wk = (j + 1) // 2 * omega
            if derivative:
                rows.append(wk * np.cos(wk * t) if j % 2 else -wk * np.sin(wk * t))
            else:
                rows.append(np.sin(wk * t) if j % 2 else np.cos(wk * t))
        return np.array(rows)

    def _build(self) -> None:
        n_p, n_b, n_x = self.n_p, self.n_b, self.n_x
        qp, x = ca.SX.sym("qp", n_p), ca.SX.sym("x", n_x)
        w, v = ca.SX.sym("w", n_b), ca.SX.sym("v", n_b)
        n_phi = max(self.basis_terms)
        lam, phi = ca.SX.sym("lam", self.n_lambda), ca.SX.sym("phi", n_phi)
        q = ca.vertcat(qp, x)
        G = self.robot.platform.null_basis(qp)  # (n_p, n_u)
        u = self.control(phi, lam)
        rates_w, rates_v = [], []
        for b in self.bounds:
            r = self._weight * (q[b.index] - b.center) ** 2
            pen = plus_function(q[b.index] - b.upper, self._sharpness)
            pen += plus_function(-q[b.index] + b.lower, self._sharpness)
            rates_w.append(r + pen)
            rates_v.append(r)
        zs = ca.vertcat(qp, w)  # states with sensitivity, (n_p + n_b,)
        fs = ca.vertcat(G @ u, *rates_w)
        fv = ca.vertcat(*rates_v) if n_b else ca.SX(0, 1)
        # Sensitivity columns: lambda and the arm joints that enter the dynamics (bounded ones).
        x_dyn = [i for i in range(n_x) if ca.depends_on(fs, x[i])]
        dyn = ca.vertcat(lam, x[x_dyn]) if x_dyn else lam
        n_zs, n_dyn = zs.numel(), dyn.numel()
        S = ca.SX.sym("S", n_zs, n_dyn)
        dS = ca.jacobian(fs, zs) @ S + ca.jacobian(fs, dyn)  # A S + B P ([JaniakTchon] s.III)
        state = ca.vertcat(zs, v, ca.vec(S))
        rhs = ca.Function("rhs", [state, phi, lam, x], [ca.vertcat(fs, fv, ca.vec(dS))])
        rhs_plain = ca.Function("rhs_plain", [qp, phi, lam], [G @ u])
        h = self.horizon / self.steps
        phi3 = ca.SX.sym("phi3", 3 * n_phi)  # basis at t, t + h/2, t + h (precomputed)
        p0, pm, p1 = phi3[:n_phi], phi3[n_phi : 2 * n_phi], phi3[2 * n_phi :]

        def rk4(f: ca.Function, s: ca.SX, *args: ca.SX) -> ca.SX:
            k1 = f(s, p0, *args)
            k2 = f(s + h / 2 * k1, pm, *args)
            k3 = f(s + h / 2 * k2, pm, *args)
            k4 = f(s + h * k3, p1, *args)
            return s + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)

        step = ca.Function("step", [state, phi3, lam, x], [rk4(rhs, state, lam, x)])
        step_plain = ca.Function("step_plain", [qp, phi3, lam], [rk4(rhs_plain, qp, lam)])
        self.step = step  # one RK4 step of state + sensitivity (SX)
        N = self.steps
        grid = np.arange(N, dtype=np.float64) * h
        times = ca.DM(
            np.vstack(
                [
                    self.basis_values(grid),
                    self.basis_values(grid + h / 2),
                    self.basis_values(grid + h),
                ]
            )
        )  # (3 n_phi, steps)

        # End point map and Jacobian: one MX function whose rollout is a loop (mapaccum)
        # over the small SX step, integrating state + sensitivity together.
        qp0_m, lam_m = ca.MX.sym("qp0", n_p), ca.MX.sym("lam", self.n_lambda)
        x_m, yd_m = ca.MX.sym("x", n_x), ca.MX.sym("yd", 3)
        s0 = ca.vertcat(qp0_m, ca.MX.zeros(2 * n_b + n_zs * n_dyn))
        roll = step.mapaccum("roll", N)
        final = roll(s0, times, ca.repmat(lam_m, 1, N), ca.repmat(x_m, 1, N))[:, -1]
        qpT, wT, vT = final[:n_p], final[n_p:n_zs], final[n_zs : n_zs + n_b]
        ST = ca.reshape(final[n_zs + n_b :], n_zs, n_dyn)  # (n_zs, n_dyn)
        select = np.zeros((n_dyn, self.n_par))  # sensitivity columns -> (lambda, x) columns
        for row, col in enumerate([*range(self.n_lambda), *(self.n_lambda + i for i in x_dyn)]):
            select[row, col] = 1.0
        k = self.robot.functions["ee_position"]
        qs, xs = ca.SX.sym("qs", n_p), ca.SX.sym("xs", n_x)
        kx = k(ca.vertcat(qs, xs))
        C = ca.Function("C", [qs, xs], [ca.jacobian(kx, qs)])(qpT, x_m)  # (3, n_p)
        D = ca.Function("D", [qs, xs], [ca.jacobian(kx, xs)])(qpT, x_m)  # (3, n_x)
        C_full = ca.diagcat(C, ca.MX.eye(n_b)) if n_b else C  # (3 + n_b, n_p + n_b)
        D_full = ca.horzcat(
            ca.MX.zeros(self.n_out, self.n_lambda), ca.vertcat(D, ca.MX.zeros(n_b, n_x))
        )
        J = C_full @ ST @ ca.DM(select) + D_full  # [JaniakTchon] eq. (7), (3 + n_b, n_par)
        e = ca.vertcat(k(ca.vertcat(qpT, x_m)) - yd_m, wT - vT)  # [JaniakTchon] eq. (19)
        self.endpoint = ca.Function(
            "endogenous_endpoint",
            [qp0_m, lam_m, x_m, yd_m],
            [ca.densify(e), ca.densify(J), ca.densify(vT)],
            ["qp0", "lam", "x", "yd"],
            ["e", "J", "regularizer"],
        )

        # Trajectory without sensitivities: q_p on the RK4 grid.
        roll_plain = step_plain.mapaccum("roll_plain", N)
        traj = ca.horzcat(qp0_m, roll_plain(qp0_m, times, ca.repmat(lam_m, 1, N)))
        self.platform_path = ca.Function("endogenous_platform_path", [qp0_m, lam_m], [traj])

        # Rates along the path: u, du/dt, dq_p = G u, ddq_p = dG/dq dq_p u + G du/dt.
        dphi = ca.SX.sym("dphi", n_phi)
        dq = G @ u
        ddq = ca.jacobian(dq, qp) @ dq + G @ self.control(dphi, lam)
        rates = ca.Function("rates", [qp, phi, dphi, lam], [u, dq, ddq])
        self.rates = rates.map("endogenous_rates", "serial", N + 1, [], [])

    # ------------------------------------------------------------------ numpy API
    def evaluate(self, qp0: Array, lam: Array, x: Array, yd: Array) -> tuple[Array, Array]:
        """Error e_r (n_out,) of [JaniakTchon] eq. (19) and Jacobian J (n_out, n_par) of eq. (7).

        J is the Jacobian of the output y_r = (k, w(T)); the bound rows include the
        regularizer, while the error's bound entries are w(T) - int r dt = int p dt: the
        derivative of the target is left out as in [JaniakTchon] eq. (13).
        """
        e, J, _ = self._endpoint(qp0, lam, x, yd)
        return e, J

    def regularizer_integrals(self, qp0: Array, lam: Array, x: Array) -> Array:
        """Targets int_0^T r(q_k) dt of the bound outputs ([JaniakTchon] eq. (19)), (n_b,)."""
        return self._endpoint(qp0, lam, x, np.zeros(3))[2]

    def times(self) -> Array:
        """Sample times of the RK4 grid, (steps + 1,)."""
        return np.linspace(0.0, self.horizon, self.steps + 1)

    def trajectory(self, qp0: Array, lam: Array) -> tuple[Array, Array, Array, Array]:
        """Platform path on the grid: q_p (N, n_p), dq_p, ddq_p (N, n_p), u (N, n_u)."""
        qp = np.asarray(self.platform_path(qp0, lam), float)  # (n_p, N)
        t = self.times()
        u, dq, ddq = self.rates(
            qp,
            self.basis_values(t),
            self.basis_values(t, derivative=True),
            ca.repmat(ca.DM(lam), 1, len(t)),
        )
        return (qp.T, np.asarray(dq, float).T, np.asarray(ddq, float).T, np.asarray(u, float).T)
