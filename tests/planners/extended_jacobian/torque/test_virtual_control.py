"""Virtual control ([PajakPajak] eqs. (24)-(31), [Pajak] eqs. (19)-(22)):
zone, cases (a)-(d), growth laws."""

from __future__ import annotations

import numpy as np
import pytest

from mmplan.planners.extended_jacobian.torque import virtual_control as vc

INF = np.inf


def test_safety_zone_eq25() -> None:
    lo, hi = vc.safety_zone(np.array([-1.5, -10.0, -INF]), np.array([1.5, 0.0, INF]), 0.1)
    np.testing.assert_allclose(lo[:2], [-1.35, -9.5])
    np.testing.assert_allclose(hi[:2], [1.35, -0.5])
    assert lo[2] == -INF and hi[2] == INF


@pytest.mark.parametrize(
    ("a", "b", "expected"),
    [
        (2.0, 0.5, (0.0, 0.25)),  # (a) a > 0, upper limit: u <= (1 - 0.5)/2
        (-2.0, -0.5, (0.0, 0.25)),  # (b) a < 0, lower limit: u <= (-1 + 0.5)/-2
        (-2.0, 1.6, (0.3, 1.0)),  # (c) a < 0, upper limit: u >= (1 - 1.6)/-2
        (2.0, -1.6, (0.3, 1.0)),  # (d) a > 0, lower limit: u >= (-1 + 1.6)/2
    ],
)
def test_cases_a_to_d(a: float, b: float, expected: tuple[float, float]) -> None:
    lo, hi = np.array([-1.0]), np.array([1.0])
    u_min, u_max = vc.feasible_interval(np.array([a]), np.array([b]), lo, hi)
    assert (u_min, u_max) == pytest.approx(expected)


def test_several_controls_eqs_28_to_30() -> None:
    lo, hi = np.full(3, -1.0), np.full(3, 1.0)
    # Only upper bounds: u = min (eq. (28)).
    u_min, u_max = vc.feasible_interval(
        np.array([2.0, 4.0, 0.0]), np.array([0.0, 0.0, 0.0]), lo, hi
    )
    assert u_max == pytest.approx(0.25) and u_min == 0.0
    # Both kinds, compatible (eq. (30) holds): nearest to the nominal value.
    a, b = np.array([2.0, 2.0, 0.0]), np.array([0.0, -1.6, 0.0])  # u <= 0.5, u >= 0.3
    choice = vc.choose(0.9, a, b, lo, hi)
    assert choice.feasible and choice.u == pytest.approx(0.5)
    choice = vc.choose(0.1, a, b, lo, hi)
    assert choice.feasible and choice.u == pytest.approx(0.3)
    # Incompatible (eq. (30) violated): reported infeasible, least violation chosen.
    a, b = np.array([2.0, 2.0]), np.array([0.6, -1.8])  # u <= 0.2 and u >= 0.4
    choice = vc.choose(1.0, a, b, lo[:2], hi[:2])
    assert not choice.feasible
    assert choice.u == pytest.approx(0.3)
    assert choice.violation == pytest.approx(0.2)


def test_choice_inside_zone_keeps_nominal_and_never_pushes_others_out() -> None:
    lo, hi = np.full(2, -1.0), np.full(2, 1.0)
    assert vc.choose(0.7, np.array([0.5, 0.1]), np.array([0.0, 0.0]), lo, hi).u == 0.7
    # Control 0 leaves the zone at u = 0.9; control 1 would leave it below u = 0.5.
    choice = vc.choose(0.9, np.array([2.0, -2.0]), np.array([-0.8, 2.0]), lo, hi)
    assert choice.feasible and 0.5 - 1e-12 <= choice.u <= 0.9
    tau = np.array([2.0, -2.0]) * choice.u + np.array([-0.8, 2.0])
    assert np.all(tau <= 1.0 + 1e-12) and np.all(tau >= -1.0 - 1e-12)


def test_control_without_lever_outside_zone_is_infeasible() -> None:
    choice = vc.choose(0.5, np.array([0.0]), np.array([2.0]), np.array([-1.0]), np.array([1.0]))
    assert not choice.feasible and choice.violation == pytest.approx(1.0)


def test_growth_laws_integrate_their_odes() -> None:
    # Constant law ([PajakPajak] eq. (31)) against a fine Euler integration.
    u, dt, rho = 0.2, 0.01, 1.5
    fine = u
    for _ in range(1000):
        fine += 1e-5 * rho * (1 - fine)
    assert vc.grow(u, dt, vc.Growth.CONSTANT, rho, 0.01, 10.0, 0.0) == pytest.approx(fine, abs=1e-6)
    # Distance law ([Pajak] eqs. (21)-(22)): rate 1/rho_min at the goal, ~1/rho_max far away.
    near = vc.grow(0.0, 1e-4, vc.Growth.DISTANCE, 1.0, 0.01, 10.0, 0.0)
    far = vc.grow(0.0, 1e-4, vc.Growth.DISTANCE, 1.0, 0.01, 10.0, 50.0)
    assert near == pytest.approx(1 - np.exp(-1e-4 / 0.01))
    assert far == pytest.approx(1 - np.exp(-1e-4 / 10.0))
    rho_t = 10.0 - (10.0 - 0.01) * np.exp(-2.0)
    assert vc.grow(0.5, 0.1, vc.Growth.DISTANCE, 1.0, 0.01, 10.0, 2.0) == pytest.approx(
        1 - 0.5 * np.exp(-0.1 / rho_t)
    )
