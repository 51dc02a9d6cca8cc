"""Extended-Jacobian planner (papers 000, 003): the four paper scenarios and per-step timing.

Part 1 plans ``youbot4r-reach``, ``youbot4r-reach-smooth``, ``youbot3r-obstacles`` and
``youbot3r-obstacles-torque`` with the generator compiled to C (CasADi code generation) and
prints T(1 cm) / T(1 mm), clearance (exact geometry, original obstacles), torque maxima and
limit violation, max cond(E), peak platform speed, manipulability, and motion duration /
compute time (rollout only, and including the one-off symbolic build and C compilation).

Part 2 times one generator step at the same state, compiled C against the baseline of the
same CasADi SX functions evaluated by CasADi's virtual machine (not code-generated), in the
same run: the ``terms`` call (E^-1 v1, E^-1 v2, push, damping, tau split), the RK4 ``step``
call, and the online step a control loop would call (``terms`` + the virtual-control choice:
state in, ddq, tau, u out).

Part 3 (``--random N``): N seeded random youbot-3r scenarios (goals in every direction at
1-4 m, heights 0-0.45 m, 1-4 random cylinders/spheres/boxes near the straight line, with and
without torque limits), planned through the scenario schema and the real scene; every plan
that reports ``reached`` is re-verified by :func:`mmplan.check.check`; the others must end
with an honest status. Prints the reached fraction and each failure.

Run: ``python bench/bench_extended_jacobian.py`` (first run compiles C: about 30-60 s a model),
``python bench/bench_extended_jacobian.py --random 30`` for part 3 only (uncompiled, ~10 min).
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from mmplan.planners import virtual_control as vc
from mmplan.planners.ej_criterion import build_criterion, choose_partition
from mmplan.planners.ej_dynamics import ObstacleTerm, build_functions
from mmplan.planners.extended_jacobian import ExtendedJacobian, ExtendedJacobianSettings
from mmplan.scenario import load_scenario
from mmplan.task import ReachPoint, completion_time

SCENARIOS = (
    "youbot4r-reach",
    "youbot4r-reach-smooth",
    "youbot3r-obstacles",
    "youbot3r-obstacles-torque",
)
PAPER = {
    "youbot4r-reach": "7.13 s",
    "youbot4r-reach-smooth": "7.34 s",
    "youbot3r-obstacles": "44.6 s",
    "youbot3r-obstacles-torque": "49.4 s",
}


def plan_scenarios() -> None:
    """Part 1: the four paper scenarios, compiled."""
    print(
        "scenario                    status   T1cm   T1mm  paper   clear  |tau|max (violation)"
        "   cond(E)  v_max   mu0->mu1         motion/compute (incl. build)"
    )
    for name in SCENARIOS:
        problem = load_scenario(name).build()
        settings = problem.settings
        assert isinstance(settings, ExtendedJacobianSettings)
        problem = dataclasses.replace(
            problem, settings=settings.model_copy(update={"codegen": True})
        )
        result = ExtendedJacobian().plan(problem)
        tr, robot, task = result.trajectory, problem.robot, problem.task
        assert isinstance(task, ReachPoint)
        err = np.linalg.norm(tr.ee - np.asarray(task.position), axis=1)
        t1, t2 = completion_time(tr.t, err, 1e-2), completion_time(tr.t, err, 1e-3)
        clear = "   -  "
        if problem.scene.obstacles:
            points = np.vstack([robot.collision_points(q) for q in tr.q])
            clear = f"{float(problem.scene.distances(points).min()):6.3f}"
        assert tr.tau is not None
        lo, hi = robot.limits.torque_min, robot.limits.torque_max
        viol = float(np.max(np.maximum(np.maximum(tr.tau - hi, lo - tr.tau), 0.0)))
        wheels = np.abs(tr.tau[:, :2]).max(axis=0)
        speed = float(np.hypot(tr.dq[:, 0], tr.dq[:, 1]).max())
        rollout_s = result.compute_time_s - float(result.info["build_time_s"])
        mu0, mu1 = robot.manipulability(tr.q[0]), robot.manipulability(tr.q[-1])
        print(
            f"{name:27s} {result.status.value:8s} {_f(t1)} {_f(t2)} {PAPER[name]:7s} {clear} "
            f"wheels {wheels[0]:.2f}/{wheels[1]:.2f} ({viol:.3f})  "
            f"{result.info['max_cond_E']:8.3g} {speed:5.2f}  {mu0:.5f}->{mu1:.5f}  "
            f"{tr.duration / rollout_s:6.1f} ({tr.duration / result.compute_time_s:5.2f})"
        )
        if result.info.get("infeasible_samples"):
            print(f"    {result.message}")
        print(
            f"    steps {len(tr.t)}, rollout {rollout_s:.2f} s = "
            f"{rollout_s / len(tr.t) * 1e6:.0f} us/step, "
            f"build {result.info['build_time_s']:.1f} s, "
            f"min perturbation scale {result.info['min_perturbation_scale']:.3f}"
        )


def _f(value: float | None) -> str:
    return "  -  " if value is None else f"{value:6.2f}"


def _time(fn: object, calls: int) -> float:
    start = time.perf_counter()
    for _ in range(calls):
        fn()  # type: ignore[operator]
    return (time.perf_counter() - start) / calls * 1e6


def time_steps() -> None:
    """Part 2: per-step microseconds, compiled C vs CasADi's SX virtual machine."""
    problem = load_scenario("youbot3r-obstacles-torque").build()
    settings = problem.settings
    assert isinstance(settings, ExtendedJacobianSettings) and isinstance(problem.task, ReachPoint)
    robot, q = problem.robot, problem.start
    crit = build_criterion(robot, choose_partition(robot, q), settings.penalty_weight)
    obstacles = [
        ObstacleTerm(
            ob.enlarged(settings.obstacle_margin).superellipsoid(),
            ob.influence or settings.influence,
        )
        for ob in problem.scene.obstacles
    ]
    p = np.concatenate(
        [problem.task.position, [settings.lambda_p, settings.lambda_v, settings.lambda_ii]]
    )
    rng = np.random.default_rng(0)
    dq = robot.null_basis(q) @ rng.normal(size=robot.n - robot.h) * 0.1
    ext = np.zeros(robot.n)
    lo, hi = vc.safety_zone(robot.limits.torque_min, robot.limits.torque_max, 0.1)
    rows = {}
    for label, codegen in (("SX virtual machine (baseline)", False), ("compiled C", True)):
        fns = build_functions(
            robot, crit, obstacles, settings.varrho, settings.arm_gradient_weight, codegen=codegen
        )

        def online(fns: object = fns) -> tuple[np.ndarray, np.ndarray, float]:
            out = fns.evaluate(q, dq, p)  # type: ignore[attr-defined]
            f0, fv, T0, Tm = out.f0, out.fv, out.T0, out.Tm
            choice = vc.choose(0.5, Tm @ fv, T0 + Tm @ f0, lo, hi)
            ddq = f0 + choice.u * fv
            return ddq, T0 + Tm @ ddq, choice.u

        calls = 300 if not codegen else 3000
        rows[label] = (
            _time(lambda fns=fns: fns.evaluate(q, dq, p), calls),
            _time(lambda fns=fns: fns.advance(q, dq, 0.5, 1.0, ext, p, 0.002), calls // 2),
            _time(online, calls),
        )
    print(
        "\nper call [us] (youbot-3r, 3 obstacles)   terms    RK4 step   online step (ddq, tau, u)"
    )
    for label, (a, b, c) in rows.items():
        print(f"  {label:35s} {a:8.1f} {b:10.1f} {c:12.1f}")
    base, comp = rows["SX virtual machine (baseline)"], rows["compiled C"]
    print(
        f"  speed-up                            {base[0] / comp[0]:8.1f} {base[1] / comp[1]:10.1f}"
        f" {base[2] / comp[2]:12.1f}"
    )


def random_scenario(rng: np.random.Generator, index: int) -> dict[str, object]:
    """A random youbot-3r scenario in the YAML form (SPEC section 8)."""
    angle, dist = rng.uniform(-np.pi, np.pi), rng.uniform(1.0, 4.0)
    goal = [dist * np.cos(angle), dist * np.sin(angle), rng.uniform(0.0, 0.45)]
    obstacles: list[dict[str, object]] = []
    for _ in range(int(rng.integers(1, 5))):
        along = rng.uniform(0.3, 0.8)
        c = np.asarray(goal[:2]) * along + rng.normal(0.0, 0.4, 2)
        kind = rng.choice(["cylinder", "sphere", "box"])
        if kind == "cylinder":
            obstacles.append(
                {
                    "shape": "cylinder",
                    "base_center": [c[0], c[1], 0.0],
                    "radius": rng.uniform(0.1, 0.3),
                    "height": rng.uniform(0.05, 0.3),
                }
            )
        elif kind == "sphere":
            obstacles.append(
                {
                    "shape": "sphere",
                    "center": [c[0], c[1], rng.uniform(0.3, 0.6)],
                    "radius": rng.uniform(0.08, 0.15),
                }
            )
        else:
            obstacles.append(
                {
                    "shape": "box",
                    "center": [c[0], c[1], 0.1],
                    "size": [rng.uniform(0.1, 0.4), rng.uniform(0.1, 0.4), 0.2],
                    "yaw": rng.uniform(-np.pi, np.pi),
                }
            )
    data: dict[str, object] = {
        "name": f"random-{index}",
        "robot": "youbot-3r",
        "start": [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -0.17, 0.35],
        "goal": {"position": [float(v) for v in goal], "tolerance": 0.001},
        "obstacles": obstacles,
        "planner": {"method": "extended-jacobian", "t_max": 60},
    }
    if index % 2:
        data["limits"] = {"torque": "unlimited"}
    return data


def random_scenarios(count: int, seed: int = 7) -> None:
    """Part 3: seeded random scenarios; reached plans must pass the independent check."""
    from mmplan.check import check
    from mmplan.errors import InputError
    from mmplan.scenario import Scenario

    rng = np.random.default_rng(seed)
    tally: dict[str, int] = {}
    for i in range(count):
        data = random_scenario(rng, i)
        try:
            problem = Scenario.from_dict(data, f"random-{i}").build()
            result = ExtendedJacobian().plan(problem)
        except InputError as exc:
            tally["input error"] = tally.get("input error", 0) + 1
            print(f"{i:3d} input error (exit 2): {exc}")
            continue
        verdict = ""
        if result.status.value == "reached":
            failures = check(result.trajectory, problem, result.status.value).failures()
            verdict = "check ok" if not failures else "CHECK FAILED: " + "; ".join(failures)
        key = result.status.value + (" (check failed)" if "FAILED" in verdict else "")
        tally[key] = tally.get(key, 0) + 1
        goal = data["goal"]["position"]  # type: ignore[index]
        print(
            f"{i:3d} goal {np.round(goal, 2)} obstacles {len(data['obstacles'])} "  # type: ignore[arg-type]
            f"limits {'no ' if i % 2 else 'yes'} {result.status.value:10s} "
            f"T {result.trajectory.t[-1]:6.2f} s {verdict} {result.message[:90]}"
        )
    print("tally:", tally)


if __name__ == "__main__":
    import sys

    if len(sys.argv) > 2 and sys.argv[1] == "--random":
        random_scenarios(int(sys.argv[2]))
    else:
        plan_scenarios()
        time_steps()
