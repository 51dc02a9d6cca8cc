"""Speed pieces of the extended-Jacobian planner against their plain references.

Exact obstacle culling (obstacles.py) against the full sum, the fused/culled record step and
the flat chunk (step.py) against the SX reference step, power_sym against x**a, and the
generator cache (cache.py). Everything is evaluated by the CasADi VM (no C compiling).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import casadi as ca
import numpy as np
import pytest

from mmplan.compile import codegen
from mmplan.planners.extended_jacobian import cache as ej_cache
from mmplan.planners.extended_jacobian import obstacles as ej_obstacles
from mmplan.planners.extended_jacobian.criterion import Partition, build_criterion, choose_partition
from mmplan.planners.extended_jacobian.generator import (
    GeneratorFunctions,
    build_functions,
    wheel_metric_inverse,
)
from mmplan.planners.extended_jacobian.obstacles import ObstacleTerm, obstacle_penalty
from mmplan.planners.extended_jacobian.parameters import ParameterLayout, slots_for
from mmplan.planners.extended_jacobian.slots import slot_terms
from mmplan.planners.extended_jacobian.step import CHUNK, build_chunk_flat
from mmplan.robot.library import youbot_3r
from mmplan.robot.robot import Robot
from mmplan.scenario.loader import load_scenario
from mmplan.scene.smooth_model import SuperellipsoidModel, power_sym

Array = np.ndarray
VARRHO = 1.7
DELTA = 0.3
GOAL, GAINS = np.array([3.5, 4.0, 0.16]), np.array([1.75, 2.78, 1.0])  # p_f, Lambdas
Setup = tuple[Robot, list[ObstacleTerm], Array]
Generator = tuple[GeneratorFunctions, dict[str, ca.Function]]
YAWED = SuperellipsoidModel((0.9, 1.7, 0.3), (0.35, 0.15, 0.3), (0.5, 0.3), 0.6)


@pytest.fixture(scope="module")
def setup() -> Setup:
    """youbot3r-obstacles (two cylinders, a sphere) plus a yawed superellipsoid; the start."""
    problem = load_scenario("youbot3r-obstacles").build()
    models = [ob.enlarged(0.05).superellipsoid() for ob in problem.scene.obstacles]
    obstacles = [ObstacleTerm(m, DELTA) for m in [*models, YAWED]]
    assert any(m.semi_axes == (m.semi_axes[0],) * 3 for m in models)  # the sphere
    return problem.robot, obstacles, np.asarray(problem.start, dtype=float)


def _configs(
    robot: Robot, obstacles: list[ObstacleTerm], rng: np.random.Generator, k: int
) -> Array:
    """k configurations: platform anywhere over the scene, or 0.2-1.2 m from an obstacle."""
    lo, hi = robot.limits.joint_min, robot.limits.joint_max
    out = np.zeros((k, robot.n))
    for row in out:
        if rng.random() < 0.3:
            row[:2] = rng.uniform([-0.8, -0.5], [2.2, 3.4])
        else:
            centre = np.asarray(_model(obstacles[rng.integers(len(obstacles))]).center)
            angle = rng.uniform(-np.pi, np.pi)
            row[:2] = centre[:2] + rng.uniform(0.2, 1.2) * np.array([np.cos(angle), np.sin(angle)])
        row[2 : robot.n_platform] = rng.uniform(-np.pi, np.pi, robot.n_platform - 2)
        row[list(robot.arm_indices)] = rng.uniform(lo, hi)
    return out


def _model(ob: ObstacleTerm) -> SuperellipsoidModel:
    """The obstacle's model (a scene superellipsoid model here)."""
    assert isinstance(ob.model, SuperellipsoidModel)
    return ob.model


def _projector(robot: Robot) -> ca.SX:
    """Wheel-metric projector into ker A (as generator.py builds it)."""
    A = robot.symbols.pfaffian
    Winv = ca.diag(ca.DM(wheel_metric_inverse(robot)))
    return ca.SX.eye(robot.n) - Winv @ A.T @ ca.solve(A @ Winv @ A.T, A)


def _box_gap(model: Any, point: Array) -> float:
    """NumPy distance of a point to the model's local bounding box."""
    d = point - np.asarray(model.center)
    c, s = np.cos(model.yaw), np.sin(model.yaw)
    local = np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1], d[2]])
    return float(np.linalg.norm(np.maximum(np.abs(local) - np.asarray(model.semi_axes), 0.0)))


def test_point_groups_partition_the_collision_points(
    setup: Setup,
) -> None:
    robot = setup[0]
    for size in (ej_obstacles.GROUP_SIZE, 3):
        groups = ej_obstacles.point_groups(robot, size)
        flat = sorted(i for g in groups for i in g)
        assert flat == list(range(len(robot.collision)))  # each point in exactly one group
        assert all(1 <= len(g) <= size for g in groups)
        assert all(len({robot.collision[i].body for i in g}) == 1 for g in groups)
    assert len(ej_obstacles.point_groups(robot)) < len(robot.collision) // 2


def test_box_gap_is_a_lower_bound_of_the_radial_distance(
    setup: Setup, rng: np.random.Generator
) -> None:
    models = [_model(ob) for ob in setup[1]]
    models.append(SuperellipsoidModel((0.2, -0.1, 0.5), (0.3, 0.5, 0.2), (2.0, 2.0), -1.1))
    p = ca.SX.sym("p", 3)
    for model in models:
        gap = ca.Function("gap", [p], [ej_obstacles.box_gap_sym(model, p)])
        axes, centre = np.asarray(model.semi_axes), np.asarray(model.center)
        points = centre + rng.uniform(-1, 1, (400, 3)) * (axes.max() + 0.8)
        G = np.asarray(gap.map(len(points))(points.T)).ravel()
        C = model.radial_distance(points)
        assert np.all(np.maximum(C, 0.0) + 1e-12 >= G)
        assert np.all(G[C < 0] == 0.0)
        assert np.mean(G > 0.1) > 0.3  # not vacuous
        c, s = np.cos(model.yaw), np.sin(model.yaw)
        rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        for k in range(3):  # tight on the axes: gap = C = t beyond the semi-axis
            direction = np.eye(3)[k]
            point = centre + rot @ direction * (axes[k] + 0.25)
            assert float(gap(point)) == pytest.approx(0.25, abs=1e-12)
            assert float(model.radial_distance(point[None])[0]) == pytest.approx(0.25, abs=1e-9)
            assert float(gap(point)) == pytest.approx(_box_gap(model, point), abs=1e-14)


def test_the_culling_test_holds_wherever_the_box_gap_is_within_reach(
    setup: Setup, rng: np.random.Generator
) -> None:
    """SlotTerm.within (squared, no square root, the excess clipped by a comparison) says 1
    wherever the box gap (NumPy, with a square root) is below reach + delta and 1e-10 m
    beyond (a group centre's rounding is ~1e-11 m 1e5 m from the origin: CULL_SLACK covers
    it), also on points placed at that distance to the last bit and on a scene 1e5 m from the
    origin, and 0 clearly beyond it (it culls)."""
    far = np.array([1e5, -1e5, 0.0])
    models = [_model(ob) for ob in setup[1]]
    models.append(SuperellipsoidModel((0.2, -0.1, 0.5), (0.3, 0.5, 0.2), (2.0, 2.0), -1.1))
    models += [SuperellipsoidModel(tuple(np.asarray(m.center) + far), m.semi_axes, m.exponents,
                                   m.yaw) for m in models[-2:]]  # fmt: skip
    layout = ParameterLayout(slots_for([m.exponents for m in models]))
    point, ps = ca.SX.sym("x", 3), ca.SX.sym("p", layout.size)
    terms = slot_terms(setup[0], layout)[1:]  # without the floor
    reach, delta = 0.13, 0.3
    for m in models:
        p = layout.pack(np.zeros(3), (1.0, 1.0, 1.0), [(m, delta)])
        at = next(t for t in terms if t.exponents == m.exponents and p[t.offset] != 1e3)
        fn = ca.Function("near", [point, ps], [at.within(point, at.numbers(ps), reach)])
        axes, centre = np.asarray(m.semi_axes), np.asarray(m.center)
        pts = centre + rng.uniform(-1, 1, (600, 3)) * (axes.max() + 0.8)
        c, s = np.cos(m.yaw), np.sin(m.yaw)
        rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        for k in range(3):  # on each axis: at the bound, an ulp either side, within the slack
            at_bound = axes[k] + reach + delta
            for d in (np.nextafter(at_bound, 0.0), at_bound, np.nextafter(at_bound, 9.0),
                      at_bound + 1e-10):  # fmt: skip
                pts = np.vstack([pts, centre + rot @ (np.eye(3)[k] * d)])
        near = np.asarray(fn.map(len(pts))(pts.T, p)).ravel()
        gaps = np.array([_box_gap(m, x) for x in pts])
        assert np.all(near[gaps < reach + delta + 1e-10] == 1.0)  # a centre's rounding
        assert np.all(near[gaps > (reach + delta) * (1.0 + 1e-6)] == 0.0)
        assert 0.1 < np.mean(near) < 0.9  # not vacuous


def test_culled_obstacle_terms_equal_the_full_sum(setup: Setup, rng: np.random.Generator) -> None:
    robot, obstacles, _ = setup
    s, n = robot.symbols, robot.n
    P = _projector(robot)
    G = np.ones(n)
    G[list(robot.arm_indices)] = 0.3
    layout = ParameterLayout(slots_for([_model(ob).exponents for ob in obstacles]))
    params = layout.pack(GOAL, GAINS, [(ob.model, ob.influence) for ob in obstacles])
    assert layout.n_slots > len(obstacles)  # parked slots too
    slots = slot_terms(robot, layout)  # the floor is off (parked)
    terms, damping = ej_obstacles.obstacle_functions(robot, slots, layout.size, P, G, VARRHO)
    # the reference: the scene's own models with their numbers built in
    K = obstacle_penalty(s.collision_points, obstacles)
    gK = ca.gradient(K, s.q)
    ref = ca.Function("ref", [s.q], [VARRHO * K, P @ (-VARRHO * (ca.DM(G) * gK)), gK])
    groups = ej_obstacles.point_groups(robot)
    local = [np.array([robot.collision[i].center for i in g]) for g in groups]
    radii = [
        max(
            np.linalg.norm(c - loc.mean(axis=0)) + robot.collision[i].radius
            for c, i in zip(loc, g, strict=True)
        )
        for loc, g in zip(local, groups, strict=True)
    ]
    active = culled = mixed = nonzero = 0
    for q in _configs(robot, obstacles, rng, 80):
        S_c, fp_c, gK_c = (np.asarray(v, dtype=float).ravel() for v in terms(q, params))
        S_r, fp_r, gK_r = (np.asarray(v, dtype=float).ravel() for v in ref(q))
        np.testing.assert_allclose(gK_c, gK_r, rtol=1e-12, atol=1e-12 * np.abs(gK_r).max())
        np.testing.assert_allclose(S_c, S_r, rtol=1e-12, atol=0.0)
        np.testing.assert_allclose(float(damping(q, params)), S_r[0], rtol=1e-12, atol=0.0)
        np.testing.assert_allclose(fp_c, fp_r, rtol=1e-12, atol=1e-12 * np.abs(fp_r).max())
        nonzero += S_r[0] > 0
        pts = robot.collision_points(q)
        here = {"active": 0, "culled": 0}
        for g, radius in zip(groups, radii, strict=True):
            centre = pts[g].mean(axis=0)
            for ob in obstacles:
                if np.any(ob.model.radial_distance(pts[g]) < ob.influence):
                    here["active"] += 1
                elif _box_gap(ob.model, centre) >= radius + ob.influence:
                    here["culled"] += 1
        active, culled = active + here["active"], culled + here["culled"]
        mixed += here["active"] > 0 and here["culled"] > 0
    counts = (nonzero, active, culled, mixed)  # 60, 328, 1467, 60 of 80 configurations
    assert nonzero >= 30 and active >= 40 and culled >= 500 and mixed >= 30, counts


@pytest.fixture(scope="module")
def generator(
    setup: Setup,
) -> Generator:
    """The SX reference generator and the functions of its codegen branch (culled), which
    ``compile_library`` would compile: captured here, not compiled (it returns None); the
    reference record step and chunk as ``ref_record``, ``ref_chunk``."""
    robot, obstacles, start = setup
    crit = build_criterion(robot, choose_partition(robot, start), 0.01, parametric=True)
    made: dict[str, ca.Function] = {}

    def capture(functions: Callable[[], list[ca.Function]], *args: Any, **kwargs: Any) -> None:
        made.update({f.name(): f for f in functions()})

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(codegen, "compile_library", capture)
        fns = build_functions(robot, crit, obstacles, VARRHO, 0.3, codegen=True)
    assert not fns.compiled and made["mmplan_ej_record_step"].class_name() == "MXFunction"
    assert fns.record is not None and fns.chunk is not None
    assert fns.layout.n_arm == 3  # the partition is a parameter
    made.update(ref_record=fns.record, ref_chunk=fns.chunk)
    return fns, made


def _params(fns: GeneratorFunctions, setup: Setup) -> Array:
    """p of the generator fixture's scene: the obstacles, a floor 5 cm below z = 0."""
    robot, obstacles, start = setup
    pairs = [(ob.model, ob.influence) for ob in obstacles]
    part = choose_partition(robot, start)
    return fns.layout.pack(GOAL, GAINS, pairs, (-0.05, 0.2), part)


def _states(setup: Setup, fns: GeneratorFunctions, k: int) -> Iterator[tuple[Array, Array]]:
    """k (x = [q; dq], par) with obstacles active (S > 0, every point at least 5 cm outside
    every obstacle) and dq violating A dq = 0."""
    robot, obstacles, _ = setup
    rng = np.random.default_rng(7)
    n, found = robot.n, 0
    params = _params(fns, setup)
    for q in _configs(robot, obstacles, rng, 200):
        dq = 0.4 * rng.normal(size=n)
        if found == k:
            return
        pts = robot.collision_points(q)
        clear = min(float(ob.model.radial_distance(pts).min()) for ob in obstacles)
        if clear < 0.05 or fns.evaluate(q, dq, params).S <= 0:
            continue
        found += 1
        par = np.concatenate(
            [params, [rng.uniform(0, 1), rng.uniform(0.5, 1)], 0.3 * rng.normal(size=n), [0.01]]
        )
        yield np.concatenate([q, dq]), par
    assert found == k


def test_culled_record_step_equals_the_reference(setup: Setup, generator: Generator) -> None:
    fns, made = generator
    culled, culled_step = made["mmplan_ej_record_step"], made["mmplan_ej_step_flat"]
    n, k = fns.n, fns.layout.size
    for x, par in _states(setup, fns, 12):
        ref = [np.asarray(v).ravel() for v in made["ref_record"](x, par)]
        got = [np.asarray(v).ravel() for v in culled(x, par)]
        for a, b in zip(got, ref, strict=True):
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * np.abs(b).max())
        flat = np.concatenate([x, par[k : k + 2 + n], par[:k], par[-1:]])
        plain = np.asarray(fns.step_flat(flat)).ravel()  # five-evaluation reference step
        np.testing.assert_allclose(
            np.asarray(culled_step(flat)).ravel(),
            plain,
            rtol=1e-10,
            atol=1e-10 * np.abs(plain).max(),
        )
        np.testing.assert_allclose(ref[0], plain, rtol=1e-10, atol=1e-10 * np.abs(plain).max())


def test_step_projects_the_velocity_into_ker_a(setup: Setup, generator: Generator) -> None:
    fns, made = generator
    robot, n, k = setup[0], fns.n, fns.layout.size
    for x, par in _states(setup, fns, 6):
        assert np.linalg.norm(robot.pfaffian(x[:n]) @ x[n:]) > 0.05  # start violates A dq = 0
        flat = np.concatenate([x, par[k : k + 2 + n], par[:k], par[-1:]])
        outs = [np.asarray(fns.step_flat(flat)).ravel()]
        outs += [
            np.asarray(f(x, par)[0]).ravel()
            for f in (made["ref_record"], made["mmplan_ej_record_step"])
        ]
        for y in outs:
            residual = robot.pfaffian(y[:n]) @ y[n:]
            assert np.linalg.norm(residual) < 1e-12 * (1 + np.linalg.norm(y[n:])), residual


def test_chunk_flat_is_the_chunk_plus_e(setup: Setup, generator: Generator) -> None:
    """chunk_flat = [vec X; vec REC; vec E(q0); vec EFF], EFF = [Tm dq; Tg] at each step's
    start, checked against the reference ``terms`` (independent of the ``effort`` function)."""
    fns, made = generator
    n, k = fns.n, fns.layout.size
    x, par = next(_states(setup, fns, 1))
    ref_flat = build_chunk_flat(made["ref_chunk"], fns.E, fns.effort)
    pairs = [
        (ref_flat, made["ref_chunk"], made["ref_record"]),
        (made["mmplan_ej_chunk_flat"], made["mmplan_ej_chunk"], made["mmplan_ej_record_step"]),
    ]
    for flat, chunk, record in pairs:
        X, REC = (np.asarray(v) for v in chunk(x, par))
        assert X.shape == (2 * n, CHUNK)
        E0 = np.asarray(fns.E(x[:n], par[:k]))
        starts = np.column_stack([x, X[:, :-1]])
        eff = []
        for col in starts.T:
            terms = fns.evaluate(col[:n], col[n:], par[:k])
            eff.append(np.concatenate([terms.Tm @ col[n:], terms.Tg]))
        expected = np.concatenate([X.ravel(order="F"), REC.ravel(order="F"), E0.ravel(order="F")])
        got = np.asarray(flat(np.concatenate([x, par]))).ravel()
        np.testing.assert_array_equal(got[: len(expected)], expected)
        want = np.concatenate(eff)
        np.testing.assert_allclose(
            got[len(expected) :], want, rtol=1e-12, atol=1e-12 * abs(want).max()
        )
        state = x
        for j in range(3):  # column j: state after step j, record at its start
            nxt, rec = (np.asarray(v).ravel() for v in record(state, par))
            np.testing.assert_allclose(X[:, j], nxt, rtol=1e-12, atol=1e-12 * np.abs(nxt).max())
            np.testing.assert_allclose(REC[:, j], rec, rtol=1e-12, atol=1e-12 * np.abs(rec).max())
            state = nxt


@pytest.mark.parametrize(
    "a", [-3.0, -2.5, -1.0, -0.5, -0.05, 0.0, 0.5, 1.0, 1.5, 2.0, 1 / 3, 0.7, 5.0, 10.0, 31.0, 33.5]
)
def test_power_sym_value_and_derivative(a: float) -> None:
    x = ca.SX.sym("x")
    f = ca.Function("f", [x], [power_sym(x, a), ca.jacobian(power_sym(x, a), x)])
    for v in (1e-3, 0.37, 1.0, 2.5, 17.0):
        value, slope = (float(w) for w in f(v))
        assert value == pytest.approx(v**a, rel=1e-14)
        assert slope == pytest.approx(a * v ** (a - 1), rel=1e-13, abs=0.0)
    xv = ca.SX.sym("xv", 3)
    out = ca.Function("g", [xv], [power_sym(xv, a)])(ca.DM([0.2, 1.0, 4.0]))
    np.testing.assert_allclose(np.asarray(out).ravel(), np.array([0.2, 1.0, 4.0]) ** a, rtol=1e-14)


@pytest.fixture
def fresh_cache() -> Iterator[None]:
    ej_cache.clear()
    yield
    ej_cache.clear()


def test_generator_cache(setup: Setup, fresh_cache: None) -> None:
    robot, obstacles, start = setup
    part = choose_partition(robot, start)

    def build(
        rob: Robot = robot,
        part: Partition = part,
        obs: list[ObstacleTerm] = obstacles,
        varrho: float = 1.0,
    ) -> ej_cache.Built:
        slots = slots_for([_model(ob).exponents for ob in obs])
        return ej_cache.generator(rob, part, slots, 0.01, varrho, 0.3, False)

    first = build()
    assert not first.cached and first.build_time > 0
    again = build()
    assert again.cached and again.build_time == 0.0 and again.fns is first.fns
    moved = [  # another scene of the same shape types: the same function
        ObstacleTerm(SuperellipsoidModel((9.0, 1.0, 0.2), (0.1, 0.2, 0.3), m.exponents), 0.1)
        for m in (_model(o) for o in obstacles)
    ]
    assert build(obs=moved).fns is first.fns
    other_part = Partition((0, 1, 2, 3, 4, 7), (5, 6))  # platform + q3: a value of p
    assert other_part != part and build(part=other_part).fns is first.fns
    built_in = Partition((0, 1, 2, 3, 5, 6), (4, 7))  # not platform + one arm joint
    for built in (build(rob=youbot_3r.build()), build(obs=obstacles[:2]), build(part=built_in)):
        assert not built.cached and built.fns is not first.fns
    assert first.fns.layout.n_arm == 3 and build(part=built_in).fns.layout.n_arm == 0
    assert build().cached
    ej_cache.clear()  # LRU: SIZE generators kept; the least recently used one is dropped
    keys = [1.0 + 0.1 * i for i in range(ej_cache.SIZE)]
    fns = [build(varrho=v).fns for v in keys]
    assert build(varrho=keys[0]).fns is fns[0]  # now the most recently used
    assert not build(varrho=9.0).cached
    assert build(varrho=keys[0]).fns is fns[0] and build(varrho=keys[-1]).fns is fns[-1]
    assert not build(varrho=keys[1]).cached


def test_culled_record_step_near_the_goal_equals_the_reference(
    setup: Setup, generator: Generator
) -> None:
    """Within 0.3 m of the goal the push loses its end-effector part (near_goal.py): the culled
    step computes that projection behind a conditional; same values as the SX reference."""
    from mmplan.planners.extended_jacobian import near_goal as ej_nearpush

    fns, made = generator
    robot, n = setup[0], fns.n
    projected = 0
    for x, par in _states(setup, fns, 12):
        par = par.copy()
        par[:3] = robot.ee_position(x[:n]) + np.array([0.05, -0.03, 0.02])  # goal 6 cm away
        K = fns.evaluate(x[:n], x[n:], par[: fns.layout.size]).S / VARRHO
        projected += K < ej_nearpush.K_HI  # fade > 0: the projection acts
        ref = [np.asarray(v).ravel() for v in made["ref_record"](x, par)]
        got = [np.asarray(v).ravel() for v in made["mmplan_ej_record_step"](x, par)]
        for a, b in zip(got, ref, strict=True):
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * np.abs(b).max())
    assert projected >= 3, projected
