"""Numerics of the endogenous planner's model ([JaniakTchon]): plus function, controls, end point
map and its Jacobian (eq. (7)) against independent references (finite differences,
scipy's solve_ivp on the paper's car equations (16), closed forms)."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from mmplan.planners.endogenous.model import (
    EndogenousModel,
    ResolvedBound,
    plus_function,
)
from mmplan.planners.endogenous.output import ArmBox, blend, wrap_arm
from mmplan.robot.library import get_robot

L2 = L3 = 0.5
A_SHARP = 50.0
PSI, X2 = 3, 5  # indices of psi and x2 in q = (x, y, phi, psi, x1, x2, x3)


@pytest.fixture(scope="module")
def robot():  # type: ignore[no-untyped-def]
    return get_robot("car-rtr")


@pytest.fixture(scope="module")
def model(robot):  # type: ignore[no-untyped-def]
    bounds = [ResolvedBound(PSI, -0.8, 0.6), ResolvedBound(X2, 0.0, 3.0)]
    return EndogenousModel(robot, 1.5, (3, 5), 120, bounds, A_SHARP, 1.0)


def softplus_ref(x: np.ndarray | float) -> np.ndarray:
    """p(x, a) = x + ln(1 + exp(-a x)) / a ([JaniakTchon] eq. (2)), overflow-free via logaddexp."""
    return np.logaddexp(0.0, A_SHARP * np.asarray(x)) / A_SHARP


def controls_ref(t: float, lam: np.ndarray, T: float) -> np.ndarray:
    """u1 = l0 + l1 sin wt + l2 cos wt; u2 = l3 + l4 sin wt + ... + l7 cos 2wt (eq. (17))."""
    w = 2 * np.pi / T
    u1 = lam[0] + lam[1] * np.sin(w * t) + lam[2] * np.cos(w * t)
    u2 = (
        lam[3]
        + lam[4] * np.sin(w * t)
        + lam[5] * np.cos(w * t)
        + lam[6] * np.sin(2 * w * t)
        + lam[7] * np.cos(2 * w * t)
    )
    return np.array([u1, u2])


def reference_error(qp0, lam, x, yd, T, bounds):  # type: ignore[no-untyped-def]
    """e_r of eq. (19) from solve_ivp of eq. (16) plus the extra states of eq. (18)."""

    def rhs(t: float, s: np.ndarray) -> np.ndarray:
        _, _, phi, psi = s[:4]
        u1, u2 = controls_ref(t, lam, T)
        q = np.concatenate([s[:4], x])
        pen = [
            softplus_ref(q[b.index] - b.upper) + softplus_ref(-q[b.index] + b.lower) for b in bounds
        ]
        return np.array(
            [
                u1 * np.cos(phi) * np.cos(psi),
                u1 * np.sin(phi) * np.cos(psi),
                u1 * np.sin(psi),
                u2,
                *pen,
            ]
        )

    sol = solve_ivp(
        rhs,
        (0, T),
        np.concatenate([qp0, np.zeros(len(bounds))]),
        method="DOP853",
        rtol=1e-12,
        atol=1e-12,
    )
    xe, ye, phi = sol.y[0, -1], sol.y[1, -1], sol.y[2, -1]
    reach = L2 + L3 * np.cos(x[2])
    k = np.array(
        [xe + reach * np.cos(phi + x[0]), ye + reach * np.sin(phi + x[0]), x[1] + L3 * np.sin(x[2])]
    )  # [JaniakTchon] eq. (16)
    return np.concatenate([k - yd, sol.y[4:, -1]]), sol.y[:4, -1]


def test_plus_function_matches_closed_form_and_does_not_overflow() -> None:
    import casadi as ca

    x = ca.SX.sym("x")
    f = ca.Function("p", [x], [plus_function(x, A_SHARP)])
    for value in (-0.3, -0.01, 0.0, 0.02, 0.5):
        closed = value + np.log(1 + np.exp(-A_SHARP * value)) / A_SHARP
        assert float(f(value)) == pytest.approx(closed, rel=1e-12, abs=1e-15)
    assert float(f(0.0)) == pytest.approx(np.log(2) / A_SHARP)
    assert float(f(100.0)) == pytest.approx(100.0)
    assert float(f(-100.0)) == pytest.approx(0.0, abs=1e-300)


def test_basis_functions_are_the_papers(robot) -> None:  # type: ignore[no-untyped-def]
    unit = EndogenousModel(robot, 1.0, (3, 5), 10, [], A_SHARP, 1.0)
    t = np.array([0.3, 0.71])
    phi = unit.basis_values(t)
    expected = [
        np.ones(2),
        np.sin(2 * np.pi * t),
        np.cos(2 * np.pi * t),
        np.sin(4 * np.pi * t),
        np.cos(4 * np.pi * t),
    ]
    np.testing.assert_allclose(phi, expected, rtol=1e-14)
    h = 1e-6
    fd = (unit.basis_values(t + h) - unit.basis_values(t - h)) / (2 * h)
    np.testing.assert_allclose(unit.basis_values(t, derivative=True), fd, atol=1e-7)


def test_end_point_and_bound_outputs_match_solve_ivp(model, rng) -> None:  # type: ignore[no-untyped-def]
    qp0 = np.array([2.0, -1.0, 0.4, 0.1])
    lam = rng.normal(0, 0.6, 8)
    x = np.array([0.3, 1.2, 0.7])
    yd = np.array([1.0, 2.0, 1.5])
    e, _ = model.evaluate(qp0, lam, x, yd)
    e_ref, qT_ref = reference_error(qp0, lam, x, yd, model.horizon, model.bounds)
    np.testing.assert_allclose(e, e_ref, atol=1e-8)
    qp, _, _, u = model.trajectory(qp0, lam)
    np.testing.assert_allclose(qp[-1], qT_ref, atol=1e-8)
    t = model.times()
    np.testing.assert_allclose(u, [controls_ref(s, lam, model.horizon) for s in t], atol=1e-12)


def test_jacobian_matches_finite_differences(model, rng) -> None:  # type: ignore[no-untyped-def]
    qp0 = np.array([0.5, 0.5, -0.3, 0.2])
    yd = np.array([0.0, 1.0, 1.0])
    for _ in range(3):
        lam, x = rng.normal(0, 0.7, 8), rng.uniform([-1, 0.5, -1], [1, 2.5, 1])
        _, J = model.evaluate(qp0, lam, x, yd)
        assert J.shape == (5, 11)
        par, h = np.concatenate([lam, x]), 1e-6

        def output(p: np.ndarray) -> np.ndarray:
            """y_r = (k, w(T)) = e_r + (y_d, int r dt)."""
            e, _ = model.evaluate(qp0, p[:8], p[8:], yd)
            v = model.regularizer_integrals(qp0, p[:8], p[8:])
            return e + np.concatenate([yd, v])

        fd = np.zeros_like(J)
        for j in range(len(par)):
            step = np.zeros_like(par)
            step[j] = h
            fd[:, j] = (output(par + step) - output(par - step)) / (2 * h)
        np.testing.assert_allclose(J, fd, atol=1e-6 * max(1.0, np.abs(J).max()))
        # The bound rows see the regularizer r = (q - c)^2: nonzero ([JaniakTchon] eqs. (10)-(13)).
        assert np.abs(J[3:]).max(axis=1).min() > 1e-3


def test_trajectory_rates_are_consistent_and_satisfy_the_pfaffian(model, robot, rng) -> None:  # type: ignore[no-untyped-def]
    qp0 = np.array([0.0, 0.0, 1.0, -0.2])
    lam = rng.normal(0, 1.0, 8)
    qp, dqp, ddqp, _ = model.trajectory(qp0, lam)
    h = model.times()[1]

    def derivative(f: np.ndarray) -> np.ndarray:
        """Fourth-order central differences at the interior samples 2..N-3."""
        return (-f[4:] + 8 * f[3:-1] - 8 * f[1:-3] + f[:-4]) / (12 * h)

    np.testing.assert_allclose(derivative(qp), dqp[2:-2], atol=1e-5)
    np.testing.assert_allclose(derivative(dqp), ddqp[2:-2], rtol=1e-4, atol=1e-4)
    for k in range(0, len(qp), 17):
        q = np.concatenate([qp[k], [0.0, 1.0, 0.5]])
        dq = np.concatenate([dqp[k], np.zeros(3)])
        assert np.abs(robot.pfaffian(q) @ dq).max() < 1e-12


def test_blend_and_wrap(robot) -> None:  # type: ignore[no-untyped-def]
    t = np.linspace(0, 2.0, 2001)
    s, ds, dds = blend(t, 2.0)
    assert (s[0], s[-1], ds[0], ds[-1], dds[0], dds[-1]) == pytest.approx((0, 1, 0, 0, 0, 0))
    np.testing.assert_allclose(np.gradient(s, t), ds, atol=1e-5)
    np.testing.assert_allclose(np.gradient(ds, t)[1:-1], dds[1:-1], atol=1e-4)
    x0 = np.array([0.0, 1.0, np.pi / 2])
    wrapped = wrap_arm(robot, x0, np.array([7.0, 9.0, 4 * np.pi]), [])
    np.testing.assert_allclose(wrapped, [7.0 - 2 * np.pi, 9.0, 0.0], atol=1e-12)  # x2 prismatic
    kept = wrap_arm(robot, x0, np.array([7.0, 9.0, 4 * np.pi]), [6])
    assert kept[2] == pytest.approx(4 * np.pi)


def test_compiled_c_matches_the_virtual_machine(robot, rng, tmp_path, monkeypatch) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    bounds = [ResolvedBound(PSI, -0.5, 0.5)]
    vm = EndogenousModel(robot, 1.0, (3, 5), 50, bounds, A_SHARP, 1.0, codegen=False)
    c = EndogenousModel(robot, 1.0, (3, 5), 50, bounds, A_SHARP, 1.0, codegen=True)
    assert vm.backend == "vm"
    assert c.backend == ("c" if shutil.which("gcc") or shutil.which("cc") else "vm")
    assert list(tmp_path.glob("endogenous_*.so")) or c.backend == "vm"
    qp0, yd = np.array([1.0, 2.0, 0.3, 0.1]), np.array([0.0, 0.0, 1.0])
    lam, x = rng.normal(0, 0.5, 8), np.array([0.2, 1.0, 0.4])
    for got, want in zip(c.evaluate(qp0, lam, x, yd), vm.evaluate(qp0, lam, x, yd), strict=True):
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    for got, want in zip(c.trajectory(qp0, lam), vm.trajectory(qp0, lam), strict=True):
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)


def test_a_compiled_model_is_loaded_again_without_its_symbolic_build(  # type: ignore[no-untyped-def]
    robot, tmp_path, monkeypatch
) -> None:
    """A new user's audit: every process built the symbolic model again (and generated its C
    to find the library by the source). Now the library's key is the model's description."""
    if shutil.which("gcc") is None and shutil.which("cc") is None:
        pytest.skip("no C compiler")
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    bounds = [ResolvedBound(PSI, -0.5, 0.5)]
    first = EndogenousModel(robot, 1.0, (3, 5), 40, bounds, A_SHARP, 1.0, codegen=True)
    builds = []
    build = EndogenousModel._build
    monkeypatch.setattr(EndogenousModel, "_build", lambda self: builds.append(1) or build(self))
    again = EndogenousModel(robot, 1.0, (3, 5), 40, bounds, A_SHARP, 1.0, codegen=True)
    assert builds == [] and again.backend == first.backend == "c"
    other = EndogenousModel(robot, 1.0, (3, 5), 40, [ResolvedBound(PSI, -0.4, 0.4)], A_SHARP,
                            1.0, codegen=True)  # fmt: skip
    assert builds == [1] and other.disk_key() != again.disk_key()
    qp0, lam, x = np.array([1.0, 2.0, 0.3, 0.1]), np.linspace(-0.3, 0.3, 8), np.zeros(3)
    yd = np.array([0.0, 0.0, 1.0])
    for got, want in zip(again.evaluate(qp0, lam, x, yd), first.evaluate(qp0, lam, x, yd),
                         strict=True):  # fmt: skip
        np.testing.assert_array_equal(got, want)


def test_arm_box_saturating_coordinates() -> None:
    box = ArmBox(4, 3, [ResolvedBound(5, 0.0, 3.0)])  # x2 in (0, 3)
    x = np.array([0.4, 2.9, -1.0])
    xi = box.from_x(x)
    np.testing.assert_allclose(box.to_x(xi), x, atol=1e-12)
    assert xi[0] == x[0] and xi[2] == x[2]
    assert 0.0 < box.to_x(np.array([0.0, 40.0, 0.0]))[1] <= 3.0
    h = 1e-6
    fd = [
        (box.to_x(xi + h * np.eye(3)[j]) - box.to_x(xi - h * np.eye(3)[j]))[j] / (2 * h)
        for j in range(3)
    ]
    np.testing.assert_allclose(box.scale(xi), fd, atol=1e-8)
