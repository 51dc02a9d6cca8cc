"""The checker's compiled robot functions (:mod:`mmplan.verify.native`) give the reports of the
CasADi virtual machine, bit for bit, and are used only where asked for and on disk."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from mmplan import Problem, Trajectory, get_robot
from mmplan.compile.codegen import compiler
from mmplan.robot.compiled import MAX_INSTRUCTIONS
from mmplan.verify import check as check_module
from mmplan.verify.check import check
from mmplan.verify.native import (
    NAMES,
    check_functions,
    compiled_checks,
    library_path,
)
from tests.verify.test_check import model_efforts, problem

needs_cc = pytest.mark.skipif(compiler() is None, reason="no C compiler")


def wavy(samples: int = 80) -> Trajectory:
    """youbot-3r moving every coordinate (wheels slipping, arm swinging): every check has a
    nonzero number to compare (efforts, Pfaffian residual, clearance, manipulability)."""
    robot = get_robot("youbot-3r")
    t = np.linspace(0.0, 4.0, samples)
    w = np.arange(1, robot.n + 1)[None, :] * 0.3
    q = np.array([0, 0, 0, 0, 0, 0, -0.17, 0.35]) + 0.4 * np.sin(w * t[:, None])
    dq = 0.4 * w * np.cos(w * t[:, None])
    ddq = -0.4 * w**2 * np.sin(w * t[:, None])
    ee = np.array([robot.ee_position(x) for x in q])
    return Trajectory(robot.coordinates, t=t, q=q, dq=dq, ddq=ddq, ee=ee,
                      actuators=robot.actuators, tau=model_efforts(q, dq, ddq))


def scenario_problem() -> Problem:
    return problem(obstacles=[{"shape": "sphere", "center": [0.4, 0.3, 0.3], "radius": 0.1},
                              {"shape": "box", "center": [-0.5, 0.2, 0.2],
                               "size": [0.2, 0.2, 0.2]}],
                   limits={"torque": {"min": [-1.0] * 5, "max": [1.0] * 5}})


def test_outside_the_block_the_checker_uses_the_robots_own_functions() -> None:
    prob = scenario_problem()
    assert all(check_functions(prob.robot)[n] is prob.robot.functions[n] for n in NAMES)


def test_a_missing_library_is_not_built_without_asking(tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    prob = scenario_problem()
    with compiled_checks(prob.robot):
        assert all(check_functions(prob.robot)[n] is prob.robot.functions[n] for n in NAMES)
    assert not list(tmp_path.iterdir())


@needs_cc
def test_compiled_reports_equal_the_virtual_machines(tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    prob = scenario_problem()
    trajectory = wavy()
    on_vm = check(trajectory, prob, status="reached")
    with compiled_checks(prob.robot, build=True):
        pass  # the block's end waits for the build
    assert library_path(prob.robot) is not None
    with compiled_checks(prob.robot):
        functions = check_functions(prob.robot)
        assert all(functions[n] is not prob.robot.functions[n] for n in NAMES)
        compiled = check(trajectory, prob, status="reached")
    assert all(check_functions(prob.robot)[n] is prob.robot.functions[n] for n in NAMES)
    assert on_vm.max_torque_violation > 0 and on_vm.max_pfaffian_residual > 0  # not all zeros
    assert dataclasses.asdict(compiled) == dataclasses.asdict(on_vm)


def test_mapped_buffers_equal_the_casadi_matrices() -> None:
    """The buffer path of ``_mapped`` (dense outputs) against CasADi's own DM result."""
    robot = get_robot("youbot-3r")
    trajectory = wavy(17)
    columns = {"ee_position": (trajectory.q,), "collision_points": (trajectory.q,),
               "tau": (trajectory.q, trajectory.dq, trajectory.ddq),
               "pfaffian": (trajectory.q,), "manipulability": (trajectory.q,)}
    for name, cols in columns.items():
        expected = np.asarray(robot.functions[name].map(17)(*[c.T for c in cols]), dtype=float)
        got = check_module._mapped(robot.functions, name, *cols)
        assert got.shape == expected.shape and got.flags.c_contiguous
        np.testing.assert_array_equal(got, expected)


@needs_cc
def test_a_large_model_is_not_built(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """base-6dof's functions (~46k operations) exceed MAX_INSTRUCTIONS: no build, the VM."""
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    robot = get_robot("base-6dof")
    assert sum(robot.functions[n].n_instructions() for n in NAMES) > MAX_INSTRUCTIONS
    with compiled_checks(robot, build=True):
        assert check_functions(robot)["tau"] is robot.functions["tau"]
    assert library_path(robot) is None and not list(tmp_path.iterdir())
