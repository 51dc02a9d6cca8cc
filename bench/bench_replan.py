"""Compile once, re-plan live: first compile, cold and warm plans, re-plans (extended Jacobian).

On the paper scenario youbot3r-obstacles-torque (the youBot's torque and rate limits, three
obstacles, the floor), in one run:

1. first compile of the robot model: the generator built and compiled to C into an empty
   temporary cache folder (``MMPLAN_CACHE``), with the scenario's shape types;
2. cold plan: a plan in a "new process" (the in-memory generator cache cleared, the compiled
   library on disk: loaded without building the symbolic model), and warm plans (generator
   in memory), compute time and motion / compute;
3. re-plans with ``Replanner.replan`` from a moving state of the plan (with its time rate w)
   with the sphere moved (a new position each call), horizon 2 s and to the goal, each
   time-scaled under the robot's limits (the default), against the cold plan: ratios in the
   same run (best of N on a shared machine);
4. the same with the generator on CasADi's virtual machine (codegen false): the baseline.

Run: ``python bench/bench_replan.py`` (about a minute; the first step compiles).
"""

from __future__ import annotations

import dataclasses
import os
import tempfile
import time

import numpy as np

from mmplan.planners.extended_jacobian import cache as ej_cache
from mmplan.planners.extended_jacobian.planner import ExtendedJacobian
from mmplan.planners.extended_jacobian.replan import Replanner
from mmplan.problem import Problem
from mmplan.scenario.loader import load_scenario
from mmplan.scene.scene import Scene
from mmplan.scene.sphere import Sphere

NAME = "youbot3r-obstacles-torque"
REPEAT = 7


def _problem(codegen: bool) -> Problem:
    problem = load_scenario(NAME).build()
    update = {"codegen": codegen, "vibration": False}
    return dataclasses.replace(problem, settings=problem.settings.model_copy(update=update))


def first_compile() -> float:
    """Seconds to build and compile the generator into an empty cache folder."""
    problem = _problem(True)
    old = os.environ.get("MMPLAN_CACHE")
    with tempfile.TemporaryDirectory() as folder:
        os.environ["MMPLAN_CACHE"] = folder
        try:
            ej_cache.clear()
            start = time.perf_counter()
            prep = ExtendedJacobian._prepare(problem)
            seconds = time.perf_counter() - start
            assert prep.fns.compiled
        finally:
            if old is None:
                del os.environ["MMPLAN_CACHE"]
            else:
                os.environ["MMPLAN_CACHE"] = old
            ej_cache.clear()
    return seconds


def _moved(scene: Scene, k: int) -> Scene:
    sphere = Sphere((1.25 + 0.02 * (k % 10), 0.70 + 0.01 * (k % 7), 0.45), 0.15, 0.15)
    return Scene((scene.obstacles[0], sphere, scene.obstacles[2]), scene.ground)


def plans_and_replans(codegen: bool) -> dict[str, float]:
    """Cold and warm plan compute times, re-plan times [s], and the motion duration."""
    problem = _problem(codegen)
    ExtendedJacobian().plan(problem)  # compiles what is not on disk yet
    ej_cache.clear()
    cold = ExtendedJacobian().plan(problem)  # library loaded, no symbolic build
    warm = min(ExtendedJacobian().plan(problem).compute_time_s for _ in range(REPEAT))
    replanner = Replanner(problem)
    tr = cold.trajectory
    k = len(tr.t) // 3  # a moving state a third of the way
    q, dq, rate = tr.q[k], tr.dq[k], float(tr.u[k]) if tr.u is not None else 1.0
    times: dict[str, list[float]] = {"2 s": [], "goal": []}
    for j in range(REPEAT * 3):
        for label, horizon in (("2 s", 2.0), ("goal", 60.0)):
            start = time.perf_counter()
            replanner.replan(q, dq, _moved(problem.scene, j), horizon=horizon, rate=rate)
            times[label].append(time.perf_counter() - start)
    return {
        "cold": cold.compute_time_s,
        "warm": warm,
        "replan 2 s": min(times["2 s"]),
        "replan median 2 s": float(np.median(times["2 s"])),
        "replan goal": min(times["goal"]),
        "motion": tr.duration,
    }


def main() -> None:
    print(f"{NAME}: first compile of youbot-3r (empty cache): {first_compile():.2f} s")
    for label, codegen in (("compiled C", True), ("CasADi VM (baseline)", False)):
        r = plans_and_replans(codegen)
        print(
            f"{label:22s} cold plan {r['cold'] * 1e3:7.1f} ms (motion/compute "
            f"{r['motion'] / r['cold']:5.0f}), warm {r['warm'] * 1e3:7.1f} ms "
            f"({r['motion'] / r['warm']:5.0f}); re-plan, sphere moved: 2 s horizon "
            f"{r['replan 2 s'] * 1e3:6.1f} ms (median {r['replan median 2 s'] * 1e3:.1f}), "
            f"to the goal {r['replan goal'] * 1e3:6.1f} ms; cold / re-plan(2 s) "
            f"{r['cold'] / r['replan 2 s']:.0f}x"
        )


if __name__ == "__main__":
    main()
