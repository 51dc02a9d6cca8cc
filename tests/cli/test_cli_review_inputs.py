"""Review defects about input validation: every absurd value of a built-in scenario gives exit 2
and one line naming the key (no hang, no MemoryError, no internal error), through the CLI."""

from __future__ import annotations

import copy
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

import mmplan
from tests.cli.test_cli import run


def _builtin(name: str) -> dict[str, Any]:
    data = yaml.safe_load(mmplan.builtin_scenarios()[name].read_text())
    assert isinstance(data, dict)
    return data


def _set(data: dict[str, Any], path: str, value: Any) -> dict[str, Any]:
    out = copy.deepcopy(data)
    keys = [int(k) if k.isdigit() else k for k in path.replace("[", ".").replace("]", "")
            .split(".")]
    node: Any = out
    for k in keys[:-1]:
        node = node[k]
    node[keys[-1]] = value
    return out


CASES = [
    # (built-in scenario, key path, value, expected "key: problem" fragment)
    ("youbot4r-reach", "planner.t_max", True, "planner.t_max: expected a number, got True"),
    ("youbot4r-reach", "planner.t_max", "30", "planner.t_max: expected a number, got '30'"),
    ("youbot4r-reach", "planner.dt", 1e-7, "planner.dt: t_max / dt = 30 / 1e-07 = 3e+08 steps "
                                           "exceeds the limit 2e+06"),
    ("youbot4r-reach", "planner.stall_window", math.inf,
     "planner.stall_window: expected a finite number, got inf"),
    ("youbot4r-reach", "planner.virtual_control", {"rho_min": 10.0, "rho_max": 0.01},
     "planner.virtual_control.rho_min: rho_min 10 > rho_max 0.01"),
    ("youbot4r-reach", "planner.lambda_p", math.nan,
     "planner.lambda_p: expected a finite number, got nan"),
    ("youbot4r-reach", "goal.position", [1e200, 0.0, 0.3],
     "goal.position[0]: |1e+200| is out of range: magnitudes must be <= 1e+06"),
    ("youbot4r-reach", "start[2]", 1e300, "start[2]: |1e+300| is out of range"),
    ("car-rtr-free", "planner.tolerance", math.inf,
     "planner.tolerance: expected a finite number, got inf"),
    ("car-rtr-free", "planner.tolerance", 5.0, "planner.tolerance: input should be less than or "
                                               "equal to 1"),
    ("car-rtr-free", "planner.basis_terms", [301, 301],
     "planner.basis_terms[0]: input should be less than or equal to 51"),
    ("car-rtr-free", "planner.steps", 100_000_000,
     "planner.steps: input should be less than or equal to 20000"),
    ("car-rtr-free", "planner.max_iterations", 1_000_000_000,
     "planner.max_iterations: input should be less than or equal to 100000"),
    ("car-rtr-free", "planner.lambda0", [1e300, 0.5, -0.5, -0.2, 0.1, 0.1, 0.01, 0.01],
     "planner.lambda0[0]: input should be less than or equal to 10000"),
    ("car-rtr-free", "planner.horizon", 1e7, "planner.horizon: input should be less than"),
    ("car-rtr-free", "planner.gamma", math.nan, "planner.gamma: expected a finite number, got nan"),
    ("car-rtr-free", "planner.bounds", [{"coordinate": "psi", "min": -1.0, "max": 1.0},
                                        {"coordinate": "psi", "min": -0.5, "max": 0.5}],
     "planner.bounds[1].coordinate: duplicate: 'psi' is already bounded by planner.bounds[0]"),
    ("car-rtr-free", "planner.steps", True, "planner.steps: expected a number, got True"),
    ("wall-segment", "planner.resolution", 1e-5,
     "planner.resolution: a grid of 99001 x 220001 cells x 31 layers is too large"),
    ("wall-segment", "obstacles", [{"shape": "sphere", "center": [3.0, 3.0, 3.0], "radius": 0.1}],
     "obstacles: 1 given, but the manipulability-area method has no obstacle model"),
    ("wall-segment", "goal.segment.normal", [0.0, 0.6, 0.3],
     "goal.segment.normal: is parallel to the segment end - start"),
    ("diffdrive3-track", "planner.dt", 1e-8, "planner.dt: t_max / dt = 120 / 1e-08"),
    ("omni3-impedance", "planner.dt", 1e-9, "planner.dt: t_max / dt = 120 / 1e-09"),
]


@pytest.mark.parametrize(("name", "key", "value", "expected"), CASES)
def test_absurd_input_exits_2_naming_the_key(tmp_path: Path, name: str, key: str, value: Any,
                                            expected: str) -> None:
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(_set(_builtin(name), key, value)))
    result = run("plan", str(path), "--out", str(tmp_path / "out"), "-q")
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {path}: {expected}"), lines
    assert not (tmp_path / "out").exists()


def test_manipulability_is_finite_at_a_singularity() -> None:
    """car-rtr stretched arm: det(J J^T) rounds to a tiny negative number; mu must be 0, not NaN."""
    robot = mmplan.get_robot("car-rtr")
    rng = np.random.default_rng(7)
    q = np.zeros(robot.n)
    values = []
    for _ in range(200):  # arm straight (q2 = q3 = 0 up to rounding), random platform pose
        q[:] = rng.uniform(-3, 3, robot.n)
        q[list(robot.arm_indices)[1:]] = rng.uniform(-1e-9, 1e-9, robot.n - robot.n_platform - 1)
        values.append(robot.manipulability(q))
    assert np.all(np.isfinite(values)) and min(values) >= 0.0


def test_gauge_of_a_tiny_exponent_neither_overflows_nor_warns() -> None:
    """Review defect 9: e1 = 1e-6 (Q = 2e6) overflowed rho**Q with a RuntimeWarning."""
    import warnings

    from mmplan.scene._gauge import gauge

    u = np.array([[0.6, 0.8, 0.5], [1.0, 1.0, 0.2], [0.1, 0.1, 3.0], [0.0, 0.0, 0.0]])
    P, Q = 2.0, 2e6  # e2 = 1, e1 = 1e-6: the gauge tends to max(||(u1, u2)||_2, u3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        g = gauge(u, P, Q)
    expected = np.maximum(np.hypot(u[:, 0], u[:, 1]), u[:, 2])
    np.testing.assert_allclose(g, expected, rtol=1e-5)
