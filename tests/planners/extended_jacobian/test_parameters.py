"""The scene as run-time parameters of the generator (parameters.py, slots.py).

Obstacle slots against the scene's own models (NumPy), the floor term against a NumPy sum and
finite differences, the partition as numbers against the reference transversality built
for each partition, and plans that keep clear of the floor.
"""

from __future__ import annotations

import dataclasses

import casadi as ca
import numpy as np
import pytest

import mmplan
from mmplan.planners.extended_jacobian import cache as ej_cache
from mmplan.planners.extended_jacobian.criterion import Partition, build_criterion
from mmplan.planners.extended_jacobian.generator import build_functions
from mmplan.planners.extended_jacobian.parameters import SLOT_SIZE, ParameterLayout, slots_for
from mmplan.planners.extended_jacobian.planner import ExtendedJacobian
from mmplan.planners.extended_jacobian.slots import SlotTerm, slot_penalty, slot_terms
from mmplan.robot.ground import ground_sphere_indices
from mmplan.robot.library import get_robot
from mmplan.robot.robot import Robot
from mmplan.scene.scene import Scene
from mmplan.scene.smooth_model import SuperellipsoidModel
from mmplan.scene.sphere import Sphere
from mmplan.task import ReachPoint

GAINS = (1.75, 2.78, 1.0)


@pytest.fixture(scope="module")
def robot() -> Robot:
    return get_robot("youbot-3r")


def _configs(robot: Robot, rng: np.random.Generator, k: int) -> np.ndarray:
    lo, hi = robot.limits.joint_min, robot.limits.joint_max
    Q = np.zeros((k, robot.n))
    Q[:, :3] = rng.uniform(-1.0, 1.0, (k, 3))
    Q[:, list(robot.arm_indices)] = rng.uniform(lo, hi, (k, len(lo)))
    return Q


def test_slot_gap_is_the_models_radial_distance(rng: np.random.Generator) -> None:
    """A slot's C (numbers in p) equals SuperellipsoidModel.radial_distance (NumPy)."""
    models = [
        SuperellipsoidModel((0.9, 1.7, 0.3), (0.35, 0.15, 0.3), (0.5, 0.3), 0.6),
        SuperellipsoidModel((0.1, -0.4, 0.1), (0.3, 0.3, 0.1), (0.1, 1.0), 0.0),
        SuperellipsoidModel((0.0, 0.0, 0.5), (0.2, 0.2, 0.2), (1.0, 1.0), 0.0),
        SuperellipsoidModel((-1.0, 0.5, 0.2), (0.4, 0.2, 0.2), (0.1, 0.1), -1.2),
    ]
    layout = ParameterLayout(slots_for([m.exponents for m in models]))
    p = layout.pack(np.zeros(3), GAINS, [(m, 0.3) for m in models])
    point, ps = ca.SX.sym("x", 3), ca.SX.sym("p", layout.size)
    terms = slot_terms(get_robot("youbot-3r"), layout)[1:]  # without the floor
    for m in models:
        at = next(t for t in terms if t.exponents == m.exponents and p[t.offset] != 1e3)
        fn = ca.Function("C", [point, ps], [at.gap(point, at.numbers(ps))])
        pts = np.asarray(m.center) + rng.uniform(-1.0, 1.0, (200, 3))
        got = np.asarray(fn.map(200)(pts.T, p)).ravel()
        np.testing.assert_allclose(got, m.radial_distance(pts), rtol=1e-9, atol=1e-12)
        p[at.offset : at.offset + 9] = (1e3, 1e3, 1e3, 1, 1, 1, 1, 0, 0)  # next: another slot


def test_pack_parks_free_slots_and_refuses_too_many(robot: Robot) -> None:
    model = SuperellipsoidModel((0.5, 0.5, 0.2), (0.2, 0.2, 0.2), (1.0, 1.0))
    layout = ParameterLayout(slots_for([model.exponents]))  # 2 slots for one sphere
    assert layout.slots == (((1.0, 1.0), 2),)
    p = layout.pack(np.zeros(3), GAINS, [(model, 0.3)])
    with pytest.raises(ValueError, match="no free slot"):
        layout.pack(np.zeros(3), GAINS, [(model, 0.3)] * 3)
    box = SuperellipsoidModel((0.5, 0.5, 0.2), (0.2, 0.2, 0.2), (0.1, 0.1))
    with pytest.raises(ValueError, match="no free slot"):
        layout.pack(np.zeros(3), GAINS, [(box, 0.3)])
    assert layout.accepts([(1.0, 1.0)] * 2) and not layout.accepts([(0.1, 0.1)])
    parked = p[layout.slot_offsets()[1][1] :][:SLOT_SIZE]
    assert parked[-1] == 0.0 and parked[0] == 1e3  # parked: far away, delta 0
    assert p[layout.slot_offsets()[0][1] + SLOT_SIZE - 1] == 0.3  # the sphere's delta


def test_floor_term_against_numpy_and_finite_differences(
    robot: Robot, rng: np.random.Generator
) -> None:
    """K_floor = sum over the floor's spheres of ((delta - C)/C)^2, C = z - r - h < delta;
    its gradient by central differences; no floor (parked) gives 0."""
    layout = ParameterLayout()
    terms = slot_terms(robot, layout)
    assert terms[0].exponents is None and terms[0].spheres == ground_sphere_indices(robot)
    ps = ca.SX.sym("p", layout.size)
    q = robot.symbols.q
    K = slot_penalty(robot.symbols.collision_points, robot.collision_radii, terms, ps)
    fn = ca.Function("K", [q, ps], [K, ca.gradient(K, q)])
    h, delta = 0.12, 0.25
    p = layout.pack(np.zeros(3), GAINS, ground=(h, delta))
    idx = list(ground_sphere_indices(robot))
    radii = np.asarray(robot.collision_radii)[idx]
    active = 0
    for qv in _configs(robot, rng, 60):
        C = np.maximum(robot.collision_points(qv)[idx, 2] - radii - h, 1e-3)
        want = float(np.sum(np.where(delta > C, ((delta - C) / C) ** 2, 0.0)))
        value, grad = fn(qv, p)
        assert float(value) == pytest.approx(want, rel=1e-12, abs=1e-300)
        if want > 0 and C.min() > 0.02:
            active += 1
            e = 1e-6
            for i in range(robot.n):
                d = np.zeros(robot.n)
                d[i] = e
                fd = (float(fn(qv + d, p)[0]) - float(fn(qv - d, p)[0])) / (2 * e)
                assert float(grad[i]) == pytest.approx(fd, rel=1e-5, abs=1e-6 * (1 + want))
        assert float(fn(qv, layout.pack(np.zeros(3), GAINS))[0]) == 0.0  # no floor
    assert active >= 5, active


def test_a_structurally_singular_partition_is_not_a_value(robot: Robot) -> None:
    """q1 (vertical axis) cannot complete R (Jc_R singular at every q): built in instead."""
    start = Partition((0, 1, 2, 3, 4, 6), (5, 7))
    fns = build_functions(robot, build_criterion(robot, start, parametric=True), [])
    assert fns.layout.choices == (6, 7)
    assert not fns.layout.supports(Partition((0, 1, 2, 3, 4, 5), (6, 7)))
    assert fns.layout.supports(Partition((0, 1, 2, 3, 4, 7), (5, 6)))


@pytest.mark.parametrize("arm_joint", [6, 7])
def test_partition_as_numbers_equals_the_built_in_partition(
    robot: Robot, rng: np.random.Generator, arm_joint: int
) -> None:
    """One function with the partition in p gives, for R = platform + each arm joint, the
    f0, fv of the reference build with that partition built in (symbolic solve)."""
    start = Partition((0, 1, 2, 3, 4, 6), (5, 7))
    crit = build_criterion(robot, start, parametric=True)
    fns = build_functions(robot, crit, [])
    assert fns.layout.n_arm == 3
    part = Partition((0, 1, 2, 3, 4, arm_joint), tuple(i for i in (5, 6, 7) if i != arm_joint))
    ref = build_functions(robot, build_criterion(robot, part, structured=False), [])
    assert ref.layout.n_arm == 0
    goal = np.array([0.8, -0.3, 0.3])
    for q in _configs(robot, rng, 4):
        dq = rng.normal(size=robot.n)
        got = fns.evaluate(q, dq, fns.layout.pack(goal, GAINS, partition=part))
        want = ref.evaluate(q, dq, ref.layout.pack(goal, GAINS))
        for a, b in ((got.f0, want.f0), (got.fv, want.fv)):
            np.testing.assert_allclose(a, b, rtol=1e-8, atol=1e-8 * np.abs(b).max())


def test_new_scene_of_the_same_shape_types_builds_nothing() -> None:
    """A moved obstacle and a new goal reuse the cached generator (no build, no compile)."""
    ej_cache.clear()
    problem = mmplan.load_scenario("youbot3r-obstacles").build()
    first = ExtendedJacobian._prepare(problem)
    scene = problem.scene
    ball = Sphere((1.5, 1.2, 0.5), 0.2, 0.2)  # the sphere moved and grown
    moved = Scene((scene.obstacles[0], ball, scene.obstacles[2]), scene.ground)
    other = dataclasses.replace(problem, scene=moved, task=ReachPoint((3.0, 3.5, 0.3), 1e-3))
    again = ExtendedJacobian._prepare(other)
    assert again.fns is first.fns and again.build_time == 0.0
    assert not np.array_equal(again.params, first.params)


@pytest.mark.parametrize("name", ["youbot3r-obstacles", "youbot3r-obstacles-torque"])
def test_paper_plans_keep_clear_of_the_floor(name: str) -> None:
    """The floor term keeps every floor sphere above z = 0 (the plans dipped 9 cm below it
    without it) and the plans still reach."""
    problem = mmplan.load_scenario(name).build()
    sol = ExtendedJacobian().plan(problem)
    assert sol.status.value == "reached"
    robot = problem.robot
    idx = list(ground_sphere_indices(robot))
    radii = np.asarray(robot.collision_radii)[idx]
    gap = min(float(np.min(robot.collision_points(q)[idx, 2] - radii)) for q in sol.trajectory.q)
    assert gap > 0.0, gap


def test_slot_term_sizes() -> None:
    assert SlotTerm(None, 6).size == 2 and SlotTerm((1.0, 1.0), 8).size == 9
