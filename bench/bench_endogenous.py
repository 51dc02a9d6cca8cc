"""Speed of the endogenous planner ([JaniakTchon]): compiled CasADi rollout vs NumPy/SciPy.

Both solve the same problems (docs/endogenous.md: car-rtr, q0 = (20, 0, pi/2, 0), x0 = (0, 1,
pi/2), y_d = (0, 0, 2), T = 1) with the same theta-iteration (gamma = 0.1, stop at
|e_r| < 1e-4). The baseline integrates state + sensitivity with ``scipy.integrate.solve_ivp``
(RK45, rtol 1e-8) using the paper's matrices A, B, C, D ([JaniakTchon] section III) in NumPy; the
compiled planner integrates them by RK4 inside one CasADi function per iteration.

Run: ``python bench/bench_endogenous.py`` (prints times, speed-up and the agreement).
"""

from __future__ import annotations

import os
import tempfile
import time

import numpy as np
from scipy.integrate import solve_ivp

from mmplan.arrays import Array
from mmplan.planners.endogenous import cache as endogenous_cache
from mmplan.planners.endogenous.planner import EndogenousPlanner
from mmplan.planners.endogenous.settings import BoundSetting, EndogenousSettings
from mmplan.problem import Problem
from mmplan.robot.library import get_robot
from mmplan.scene.scene import Scene
from mmplan.task import ReachPoint

L2 = L3 = 0.5
A_SHARP = 50.0
START = np.array([20.0, 0.0, np.pi / 2, 0.0, 0.0, 1.0, np.pi / 2])
LAMBDA0 = (-1.0, 0.5, -0.5, -0.2, 0.1, 0.1, 0.01, 0.01)
YD = np.array([0.0, 0.0, 2.0])
REPEAT = 3  # compiled timings: best of 3 (the machine is shared); numpy: one run


def basis_row(t: float, terms: int) -> Array:
    """phi_0..phi_{terms-1}(t) for T = 1."""
    w = 2 * np.pi
    return np.array([1, np.sin(w * t), np.cos(w * t), np.sin(2 * w * t), np.cos(2 * w * t)])[:terms]


def sigmoid(z: float) -> float:
    return float(0.5 * (1 + np.tanh(0.5 * z)))


def numpy_error_and_jacobian(lam: Array, x: Array, bound: float | None) -> tuple[Array, Array]:
    """e_r (eq. (19)) and J (eq. (7)) of [JaniakTchon] by solve_ivp of state + sensitivity."""
    nb = 0 if bound is None else 1
    nz = 4 + nb

    def rhs(t: float, s: Array) -> Array:
        _, _, phi, psi = s[:4]
        S = s[nz + nb :].reshape(nz, 8)
        P = np.zeros((2, 8))
        P[0, :3], P[1, 3:] = basis_row(t, 3), basis_row(t, 5)
        u1, u2 = P @ lam
        cp, sp, cs, ss = np.cos(phi), np.sin(phi), np.cos(psi), np.sin(psi)
        f = [u1 * cp * cs, u1 * sp * cs, u1 * ss, u2]
        A = np.zeros((nz, nz))
        A[0, 2], A[0, 3] = -u1 * sp * cs, -u1 * cp * ss
        A[1, 2], A[1, 3] = u1 * cp * cs, -u1 * sp * ss
        A[2, 3] = u1 * cs
        B = np.zeros((nz, 2))
        B[:4, 0], B[3, 1] = [cp * cs, sp * cs, ss, 0.0], 1.0
        extra = []
        if bound is not None:
            pen = np.logaddexp(0, A_SHARP * (psi - bound)) + np.logaddexp(
                0, A_SHARP * (-psi - bound)
            )
            f.append(psi**2 + pen / A_SHARP)
            A[4, 3] = 2 * psi + sigmoid(A_SHARP * (psi - bound)) - sigmoid(A_SHARP * (-psi - bound))
            extra = [psi**2]
        dS = A @ S + B @ P
        return np.concatenate([f, extra, dS.ravel()])

    s0 = np.concatenate([START[:4], np.zeros(2 * nb + nz * 8)])
    sol = solve_ivp(rhs, (0.0, 1.0), s0, method="RK45", rtol=1e-8, atol=1e-10)
    end = sol.y[:, -1]
    _, _, phi = end[:3]
    S = end[nz + nb :].reshape(nz, 8)
    reach, angle = L2 + L3 * np.cos(x[2]), phi + x[0]
    k = np.array(
        [end[0] + reach * np.cos(angle), end[1] + reach * np.sin(angle), x[1] + L3 * np.sin(x[2])]
    )
    C = np.zeros((3 + nb, nz))
    C[0, 0], C[1, 1], C[0, 2], C[1, 2] = 1, 1, -reach * np.sin(angle), reach * np.cos(angle)
    D = np.zeros((3 + nb, 3))
    D[:3, 0] = [-reach * np.sin(angle), reach * np.cos(angle), 0]
    D[:3, 1] = [0, 0, 1]
    D[:3, 2] = [
        -L3 * np.sin(x[2]) * np.cos(angle),
        -L3 * np.sin(x[2]) * np.sin(angle),
        L3 * np.cos(x[2]),
    ]
    e = k - YD
    if bound is not None:
        C[3, 4] = 1.0
        e = np.append(e, end[4] - end[5])
    return e, np.hstack([C @ S, D])


def numpy_plan(bound: float | None, tol: float = 1e-4) -> tuple[int, float, Array, Array]:
    """The theta-iteration with the NumPy model; (iterations, |e|, lambda, x)."""
    lam, x = np.array(LAMBDA0), START[4:].copy()
    for it in range(5000):
        e, J = numpy_error_and_jacobian(lam, x, bound)
        if np.linalg.norm(e) < tol:
            return it, float(np.linalg.norm(e)), lam, x
        step = -0.1 * np.linalg.pinv(J) @ e
        lam, x = lam + step[:8], x + step[8:]
    return 5000, float(np.linalg.norm(e)), lam, x


def numpy_max_psi(lam: Array) -> float:
    """max |psi| on [0, 1]: psi(t) = int u2 dt, sampled finely."""
    t = np.linspace(0, 1, 2001)
    u2 = np.array([basis_row(s, 5) @ lam[3:] for s in t])
    psi = np.concatenate([[0.0], np.cumsum(0.5 * (u2[1:] + u2[:-1]) * np.diff(t))])
    return float(np.abs(psi).max())


def compiled_plan(
    bound: float | None, codegen: bool, reuse: bool = False
) -> tuple[float, dict[str, object]]:
    """Wall time of one EndogenousPlanner.plan and its info; the model is built afresh
    (symbolic build, C library compiled or loaded from the disk cache) unless ``reuse``."""
    if not reuse:
        endogenous_cache._MODELS.clear()
    bounds = () if bound is None else (BoundSetting(coordinate="psi", min=-bound, max=bound),)
    problem = Problem(
        get_robot("car-rtr"),
        Scene([]),
        ReachPoint((0.0, 0.0, 2.0), 1e-4),
        START,
        EndogenousSettings(lambda0=LAMBDA0, bounds=bounds, codegen=codegen),
    )
    t0 = time.perf_counter()
    result = EndogenousPlanner().plan(problem)
    return time.perf_counter() - t0, {**result.info, "status": str(result.status)}


def main() -> None:
    functions = get_robot("car-rtr").functions  # built on first use: outside the timings
    _ = [functions[name] for name in ("ee_position", "jacobian")]
    os.environ["MMPLAN_CACHE"] = tempfile.mkdtemp(prefix="mmplan-bench-")  # cold C cache
    print(
        "times [s] per solve: numpy = solve_ivp baseline; vm = CasADi virtual machine;\n"
        "C cold = C compiled now; C = library from the disk cache, model built in the run;\n"
        "C again = model reused in the process. speed-up = numpy / C (numpy / C again, "
        "numpy / vm)"
    )
    print(
        f"{'case':<9}{'numpy':>8}{'vm':>7}{'C cold':>8}{'C':>7}{'again':>7}{'speed-up':>10}"
        f"{'again':>7}{'vm':>7}{'iters np/C':>12}{'max|psi| np/C':>17}"
    )
    for name, bound in (("free", None), ("steer60", np.pi / 3), ("steer30", np.pi / 6)):
        t0 = time.perf_counter()
        iters, _, lam, _ = numpy_plan(bound)
        t_numpy = time.perf_counter() - t0
        t_vm = min(compiled_plan(bound, codegen=False)[0] for _ in range(REPEAT))
        t_cold, _ = compiled_plan(bound, codegen=True)
        t_c = min(compiled_plan(bound, codegen=True)[0] for _ in range(REPEAT))
        t_again = min(compiled_plan(bound, codegen=True, reuse=True)[0] for _ in range(REPEAT))
        _, info = compiled_plan(bound, codegen=True, reuse=True)
        print(
            f"{name:<9}{t_numpy:>8.2f}{t_vm:>7.3f}{t_cold:>8.3f}{t_c:>7.3f}{t_again:>7.3f}"
            f"{t_numpy / t_c:>9.0f}x{t_numpy / t_again:>6.0f}x{t_numpy / t_vm:>6.0f}x"
            f"{iters:>6d}/{info['iterations']:<5}"
            f"{numpy_max_psi(lam):>8.4f}/{info['max_abs.psi']:.4f} {info['status']} "
            f"({info['backend']})"
        )


if __name__ == "__main__":
    main()
