"""The robot's compiled functions (mmplan.robot.compiled): the virtual machine's numbers to the
bit, used by the numeric API when on disk, so that a warm run never builds the symbolic
model."""

from __future__ import annotations

import subprocess
import sys
import threading
from importlib import import_module
from pathlib import Path

import numpy as np
import pytest

import mmplan
from mmplan.analysis.vibration import ee_acceleration
from mmplan.compile import codegen
from mmplan.planners import culling
from mmplan.robot import compiled as robot_compiled
from mmplan.robot import get_robot
from mmplan.robot.ground import floor_clearances, ground_sphere_indices
from mmplan.robot.library import _BUILDERS
from mmplan.robot.robot import Robot

needs_cc = pytest.mark.skipif(codegen.compiler() is None, reason="no C compiler")


def _fresh(name: str = "youbot-3r") -> Robot:
    """A new robot object (``get_robot`` shares one per process, with its memos)."""
    return import_module(f"mmplan.robot.library.{_BUILDERS[name]}").build()  # type: ignore[no-any-return]


def _built(name: str = "youbot-3r") -> Robot:
    """A fresh robot object whose library is on disk (built here when missing)."""
    first = _fresh(name)
    thread = robot_compiled.start_build(first)
    if thread is not None:
        thread.join()
    ground_sphere_indices(first)  # read off the model once, then from the disk memo
    fresh = _fresh(name)
    assert fresh.compiled() is not None
    return fresh


def _vm(name: str = "youbot-3r") -> Robot:
    """A robot object that evaluates on the virtual machine whatever is on disk."""
    robot = _fresh(name)
    robot._shared["natives"] = None
    return robot


def _bits(a: np.ndarray, b: np.ndarray) -> None:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape
    np.testing.assert_array_equal(a.view(np.uint64), b.view(np.uint64))


@needs_cc
@pytest.mark.parametrize("name", ["youbot-3r", "car-rtr", "omni-3dof"])
def test_the_numeric_api_gives_the_virtual_machines_bits(name: str) -> None:
    """The youBot (h = 3), a car-like platform (h = 2) and an omnidirectional one (h = 0, an
    empty Pfaffian), at random points; the youBot also through the culling extent and the
    vibration study's accelerations."""
    robot, vm = _built(name), _vm(name)
    rng = np.random.default_rng(11)
    for _ in range(25):
        q, dq, ddq = (rng.normal(size=robot.n) for _ in range(3))
        _bits(robot.ee_position(q), vm.ee_position(q))
        _bits(robot.jacobian(q), vm.jacobian(q))
        _bits(robot.pfaffian(q), vm.pfaffian(q))
        _bits(np.array(robot.manipulability(q)), np.array(vm.manipulability(q)))
        _bits(robot.collision_points(q), vm.collision_points(q))
        _bits(robot.actuator_efforts(q, dq, ddq), vm.actuator_efforts(q, dq, ddq))
    assert "symbols" not in robot._shared  # never needed the model
    Q, dQ, ddQ = (rng.normal(size=(40, robot.n)) for _ in range(3))
    _bits(floor_clearances(robot, Q, 0.05), floor_clearances(vm, Q, 0.05))
    _bits(floor_clearances(robot, Q[:1], 0.0), floor_clearances(vm, Q[:1], 0.0))
    _bits(ee_acceleration(robot, Q, dQ, ddQ), ee_acceleration(vm, Q, dQ, ddQ))
    if name == "youbot-3r":
        start = np.array([0, 0, 0, 0, 0, 0, -0.17, 0.35])
        for a, b in zip(culling.extent(robot, start), culling.extent(vm, start), strict=True):
            _bits(np.asarray(a), np.asarray(b))
    assert "symbols" not in robot._shared


WARM_RUN = """
import sys
import mmplan
import mmplan.robot.robot as robot_module
built = []
build = robot_module.Robot._build_symbols
def spy(self):
    built.append(1)
    return build(self)
robot_module.Robot._build_symbols = spy
sc = mmplan.load_scenario("youbot3r-obstacles-torque")
result = mmplan.get_planner(sc.method)().plan(sc.build())
print(result.status.value, len(built), sc.robot.compiled() is not None)
"""


@needs_cc
def test_a_warm_scenario_and_plan_never_build_the_symbolic_model() -> None:
    """With the robot's library and the generator on disk, a process that loads the paper
    scenario (its start checks) and plans it evaluates the compiled functions only; the plan
    is the one of the virtual machine's robot functions, to the bit."""
    _built()
    sc = mmplan.load_scenario("youbot3r-obstacles-torque")
    planner = mmplan.get_planner(sc.method)()
    result = planner.plan(sc.build())  # the generator on disk (compiled here if it was not)
    run = subprocess.run([sys.executable, "-c", WARM_RUN], capture_output=True, text=True,
                         timeout=300, check=True)  # fmt: skip
    assert run.stdout.split() == ["reached", "0", "True"], run.stdout + run.stderr
    sc_vm = mmplan.load_scenario("youbot3r-obstacles-torque")
    problem = sc_vm.build()
    problem.robot._shared["natives"] = None  # the virtual machine's robot functions
    try:
        reference = planner.plan(problem)
    finally:
        problem.robot._shared.pop("natives", None)
    _bits(result.trajectory.q, reference.trajectory.q)
    _bits(result.trajectory.t, reference.trajectory.t)


@needs_cc
def test_the_lookup_follows_the_cache_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A robot that found its library in one cache folder looks again in another (a test or a
    user switching ``$MMPLAN_CACHE`` in a process)."""
    robot = _built()
    first = robot.compiled()
    assert first is not None
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    assert robot.compiled() is None  # nothing built in the empty folder
    _bits(robot.ee_position(np.zeros(robot.n)), _vm().ee_position(np.zeros(robot.n)))
    monkeypatch.undo()  # the folder of before
    assert robot.compiled() is not None


@needs_cc
def test_a_library_that_does_not_load_leaves_the_virtual_machine(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    robot = get_robot("youbot-3r")
    path = Path(codegen._library(robot_compiled.library_key(robot), robot_compiled.PREFIX,
                                 robot_compiled.FLAGS))  # fmt: skip
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"not a shared library")
    assert robot_compiled.cached_library(robot) == str(path)  # on disk...
    assert robot.compiled() is None  # ... but it does not load
    _bits(robot.ee_position(np.zeros(robot.n)), _vm().ee_position(np.zeros(robot.n)))


def test_without_a_library_nothing_is_built_by_a_call(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The numeric API looks for the library once per model and never compiles one."""
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    robot = get_robot("youbot-3r")
    assert robot.compiled() is None
    robot.ee_position(np.zeros(robot.n))
    assert not list(tmp_path.glob(f"{robot_compiled.PREFIX}_*.so"))
    assert robot._shared["natives"] == (str(tmp_path), None)  # looked up once, for this folder


@needs_cc
def test_two_threads_on_one_robot_get_their_own_results() -> None:
    """A compiled function has one set of buffers and ctypes lets other threads run during
    the call: the calls are serialised (two threads gave 200 wrong results in 12,000 before,
    found by review)."""
    robot, vm = _built(), _vm()
    rng = np.random.default_rng(4)
    Q = rng.normal(size=(300, robot.n))
    want_J = [vm.jacobian(q) for q in Q]
    want_P = [vm.collision_points(q) for q in Q]
    wrong = [0, 0]

    def run(which: int) -> None:  # both threads call the same functions
        for _ in range(4):
            for k in range(len(Q)) if which == 0 else range(len(Q) - 1, -1, -1):
                wrong[which] += not np.array_equal(robot.jacobian(Q[k]), want_J[k])
                wrong[which] += not np.array_equal(robot.collision_points(Q[k]), want_P[k])
                wrong[which] += not np.array_equal(
                    robot.compiled().many("collision_points", Q[k : k + 1])[0],  # type: ignore[union-attr]
                    want_P[k].ravel(),  # (3, P) column after column
                )

    threads = [threading.Thread(target=run, args=(i,)) for i in (0, 1)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert wrong == [0, 0]


@needs_cc
def test_a_forged_ground_memo_is_computed_again(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    want = ground_sphere_indices(_fresh())
    (memo,) = tmp_path.glob("ground_spheres_*.json")
    for forged in ("[-1]", "[true, false]", "[99]", "[3, 1]", '"x"'):
        memo.write_text(forged)
        assert ground_sphere_indices(_fresh()) == want, forged
