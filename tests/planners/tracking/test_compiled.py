"""The trackers' compiled steps with the scene as parameters (planners/tracking/compiled.py,
slots.py, mmplan/scene/parametric.py)."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np
import pytest

import mmplan
from mmplan.compile import codegen as cg
from mmplan.planners.tracking import planner as tracking_planner
from mmplan.planners.tracking.slots import Slots
from mmplan.scene import parametric
from mmplan.scene.box import Box
from mmplan.scene.cylinder import Cylinder
from mmplan.scene.scene import Scene
from mmplan.scene.sphere import Sphere

needs_cc = pytest.mark.skipif(cg.compiler() is None, reason="no C compiler")


@pytest.mark.parametrize(
    "obstacle",
    [
        Sphere((0.3, -0.2, 0.5), 0.25, None),
        Cylinder((1.0, 0.5, 0.1), 0.3, 0.6, None),
        Box((-0.4, 0.8, 0.3), (0.5, 0.2, 0.4), 0.7, None),
    ],
)
def test_the_parametric_distance_is_the_shapes_exact_distance(
    obstacle: Any, rng: np.random.Generator
) -> None:
    """Independent: the shape's NumPy distance (its own formula) at random points, inside
    and outside; the parked geometry is 1 km away."""
    kind = parametric.kind_of(obstacle)
    assert kind is not None
    p, g = ca.SX.sym("p", 3), ca.SX.sym("g", parametric.SIZES[kind])
    f = ca.Function("d", [p, g], [parametric.distance_sym(kind, p, g)])
    points = rng.uniform(-1.5, 2.0, (200, 3))
    got = np.array([float(f(x, parametric.geometry(obstacle))) for x in points])
    np.testing.assert_allclose(got, obstacle.distance(points), atol=1e-8)
    assert float(f(np.zeros(3), parametric.parked(kind))) > 900.0


def _plan(name: str, scene: Scene | None = None) -> mmplan.Solution:
    problem = mmplan.load_scenario(name).build()
    if scene is not None:
        problem = dataclasses.replace(problem, scene=scene)
    return mmplan.get_planner(problem.settings.method)().plan(problem)


@needs_cc
@pytest.mark.parametrize("name", ["diffdrive3-track", "omni3-impedance"])
def test_a_compiled_step_with_the_scene_as_numbers_plans_as_the_built_in_one(
    name: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The same samples as the step with the scene's numbers built in on CasADi's virtual
    machine (as before: to the bit here, 1e-12 allowed)."""
    compiled = _plan(name)
    assert compiled.info["backend"] == "c"
    monkeypatch.setattr(tracking_planner.Slots, "of", classmethod(lambda cls, obstacles: None))
    built_in = _plan(name)
    assert built_in.info["backend"] == "vm"
    np.testing.assert_allclose(compiled.trajectory.q, built_in.trajectory.q, atol=1e-12)
    np.testing.assert_allclose(compiled.trajectory.dq, built_in.trajectory.dq, atol=1e-12)


@needs_cc
def test_moved_and_new_obstacles_of_the_same_kinds_compile_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    problem = mmplan.load_scenario("diffdrive3-track").build()
    first = _plan("diffdrive3-track")
    libraries = sorted(tmp_path.glob("track_*.so"))
    assert first.info["backend"] == "c" and len(libraries) == 1
    (cylinder,) = problem.scene.obstacles
    moved = Cylinder((2.0, 0.4, 0.0), 0.2, 0.5, None)
    for obstacles in ((moved,), (cylinder, moved)):  # moved; a second of the kind (2 slots)
        sol = _plan("diffdrive3-track", Scene(obstacles, problem.scene.ground))
        assert sol.info["backend"] == "c"
        assert sorted(tmp_path.glob("track_*.so")) == libraries
    # a new kind compiles once (the test can fail)
    ball = Sphere((1.0, 1.0, 0.3), 0.1, None)
    _plan("diffdrive3-track", Scene((cylinder, ball), problem.scene.ground))
    assert len(list(tmp_path.glob("track_*.so"))) == 2
    assert Slots.of([cylinder, ball]) == Slots((("cylinder", 2), ("sphere", 2)))


def test_without_a_compiler_the_step_runs_on_the_virtual_machine_and_says_so(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("CC", "/nonexistent/cc")
    sol = _plan("diffdrive3-track")
    assert sol.info["backend"] == "vm" and sol.status.value == "reached"
    assert "the tracker's step runs on CasADi's virtual machine" in capsys.readouterr().err


@needs_cc
def test_a_compiled_tracker_is_loaded_without_building_its_model(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A later plan finds the library by the description: no symbolic model is built (the
    audit: every process built it again); the functions a loaded model lacks are built when
    first asked for."""
    from mmplan.planners.tracking.impedance import VirtualImpedance
    from mmplan.planners.tracking.pseudoinverse import WeightedPseudoinverse

    _plan("diffdrive3-track"), _plan("omni3-impedance")  # the libraries on disk
    builds: list[str] = []
    for cls in (WeightedPseudoinverse, VirtualImpedance):

        def counted(self: Any, *args: Any, _build: Any = cls._build, _name: str = cls.__name__
                    ) -> Any:  # fmt: skip
            builds.append(_name)
            return _build(self, *args)

        monkeypatch.setattr(cls, "_build", counted)
    for name in ("diffdrive3-track", "omni3-impedance"):
        sol = _plan(name)
        assert sol.info["backend"] == "c" and sol.status.value == "reached"
    assert builds == []
    problem = mmplan.load_scenario("diffdrive3-track").build()
    slots = Slots.of(problem.scene.obstacles)
    settings = problem.settings
    from mmplan.planners.tracking import compiled

    loaded = compiled.functions(("pinv_step", "task_jacobian"), problem.robot, settings, slots,
                                problem.scene.ground, lambda: [])  # fmt: skip
    assert loaded is not None and loaded.slots == slots
    model = WeightedPseudoinverse(problem.robot, problem.scene.obstacles, settings,
                                  problem.scene.ground, slots, loaded.functions)  # fmt: skip
    q = np.asarray(problem.start, dtype=float)
    assert builds == []
    z = np.asarray(model.null_vector(q), dtype=float)  # built now, once
    assert builds == ["WeightedPseudoinverse"] and z.shape == (problem.robot.n, 1)


@needs_cc
def test_a_parked_slot_pushes_nothing_where_it_is_parked() -> None:
    """A review's case: omni3-impedance moved to (1000, 1000), where an unused slot parks its
    obstacle: the compiled plan was pushed 0.5 m by a post that is not in the scene. The slot's
    active flag switches it off: the same samples as the built-in step."""
    import yaml

    from mmplan.scenario.loader import Scenario, builtin_scenarios

    data = yaml.safe_load(builtin_scenarios()["omni3-impedance"].read_text())
    data["start"][:2] = [999.85, 999.85]  # near the parked (1000, 1000)
    data["goal"]["path"]["start"][:2] = [999.75, 999.75]
    data["obstacles"][0]["base_center"][:2] = [1001.35, 999.0]  # the post away from the path
    moved = Scenario.from_dict(data, "omni3-impedance-far").build()
    planner = mmplan.get_planner("impedance")
    compiled = planner().plan(moved)
    assert compiled.info["backend"] == "c"
    built_in = planner().plan(dataclasses.replace(
        moved, settings=moved.settings.model_copy(update={"codegen": False})))  # fmt: skip
    np.testing.assert_allclose(compiled.trajectory.q, built_in.trajectory.q, atol=1e-9)
    assert compiled.info["min_platform_obstacle_distance_m"] == pytest.approx(
        built_in.info["min_platform_obstacle_distance_m"], abs=1e-9)  # fmt: skip


def test_a_shape_subclass_keeps_its_own_distance() -> None:
    """A review's case: a padded sphere (a subclass measuring 0.3 m more) was planned with the
    plain sphere's parametric distance, 12 cm inside its padding."""

    @dataclasses.dataclass(frozen=True)
    class PaddedSphere(Sphere):
        def signed_distance_sym(self, p: Any) -> Any:
            return super().signed_distance_sym(p) - 0.3

    assert parametric.kind_of(Sphere((0, 0, 0), 1.0, None)) == "sphere"
    assert parametric.kind_of(PaddedSphere((0, 0, 0), 1.0, None)) is None
    assert Slots.of([PaddedSphere((0, 0, 0), 1.0, None)]) is None


@needs_cc
def test_an_unreadable_library_falls_back_to_the_virtual_machine(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from mmplan.planners.tracking import compiled

    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    _plan("diffdrive3-track")
    for library in tmp_path.glob("track_*.so"):
        library.write_text("not a library")  # another machine's, or damaged
    monkeypatch.setattr(compiled, "_FAILED", set())
    sol = _plan("diffdrive3-track")
    assert sol.info["backend"] == "vm" and sol.status.value == "reached"
    assert "could not be built or loaded" in capsys.readouterr().err
