"""More obstacles than slots: a library with fewer slots (near obstacles in them) vs one per count.

The obstacle count is a run-time quantity of the extended Jacobian's compiled generator
(:mod:`mmplan.planners.extended_jacobian.active`): a scene with more obstacles of a shape type
than a compiled library's slots plans with that library, the obstacles near the robot in its
slots, instead of compiling one with the scene's count. In one run, into an empty temporary
cache folder (``MMPLAN_CACHE``):

1. the paper scenario youbot3r-obstacles-torque compiles its library (2 cylinder and 2
   sphere slots) and is planned;
2. scenes with the paper's obstacles and ``extra`` more cylinders (a few near the path, the
   rest spread away from it) are planned with that library: seconds (compile included, if
   any), whether a compile ran, how often the slots were chosen;
3. the same scenes with a library holding every obstacle (``exact``: compiled here once per
   scene, its seconds reported), then warm plans of both alternated: median compute time,
   the ratio narrow / exact in the same run, and whether the samples are the same to the
   bit.

Run: ``python bench/bench_active_slots.py`` (about a minute: each scene's exact library
compiles once).
"""

from __future__ import annotations

import dataclasses
import os
import statistics
import tempfile
import time
from typing import Any

import numpy as np

from mmplan.planners.extended_jacobian import cache as ej_cache
from mmplan.planners.extended_jacobian.planner import ExtendedJacobian
from mmplan.problem import Problem
from mmplan.scenario.loader import load_scenario
from mmplan.scene.cylinder import Cylinder
from mmplan.scene.scene import Scene
from mmplan.trajectory import PlanResult

NAME = "youbot3r-obstacles-torque"
REPEAT = 9
#: Extra cylinders (x, y): three the robot passes near, then spread ones it does not.
NEAR = [(2.6, 3.6), (-0.8, 0.2), (3.5, 1.0)]
SPREAD = [(x, y) for x in (-3.0, 6.0) for y in np.linspace(-3.0, 7.0, 7)]


def _problem(extra: list[tuple[float, float]]) -> Problem:
    base = load_scenario(NAME).build()
    added = [Cylinder((float(x), float(y), 0.0), 0.15, 0.4, 0.35) for x, y in extra]
    scene = Scene((*base.scene.obstacles, *added), base.scene.ground)
    settings = base.settings.model_copy(update={"codegen": True, "vibration": False})
    return dataclasses.replace(base, scene=scene, settings=settings)


def _plan(problem: Problem, exact: bool) -> tuple[float, PlanResult]:
    """Compute seconds of one plan and the solution (``exact``: every obstacle in a slot)."""
    planner = ExtendedJacobian()
    original = ExtendedJacobian.__dict__["_prepare"]
    if exact:
        def prepare(cls: type, problem: Problem, guess: bool = False, exact: bool = False) -> Any:
            return original.__func__(cls, problem, guess, True)

        ExtendedJacobian._prepare = classmethod(prepare)  # type: ignore[method-assign,assignment]
    try:
        start = time.perf_counter()
        sol = planner.plan(problem)
        return time.perf_counter() - start, sol
    finally:
        if exact:
            ExtendedJacobian._prepare = original  # type: ignore[method-assign]


def main() -> None:
    old = os.environ.get("MMPLAN_CACHE")
    with tempfile.TemporaryDirectory() as folder:
        os.environ["MMPLAN_CACHE"] = folder
        try:
            ej_cache.clear()
            seconds, sol = _plan(_problem([]), False)
            print(f"paper scene, first compile and plan: {seconds:.2f} s, {sol.status.value}")
            print(f"{'scene':28s} {'narrow s':>9s} {'choices':>7s} {'exact s':>8s} "
                  f"{'narrow ms':>9s} {'exact ms':>8s} {'ratio':>6s} same")
            for label, extra in (
                ("+3 cylinders near the path", NEAR),
                (f"+{len(NEAR) + len(SPREAD)} cylinders", NEAR + SPREAD),
            ):
                problem = _problem(extra)
                ej_cache.clear()  # as a new process
                first, narrow = _plan(problem, False)
                choices = narrow.info.get("slot_choices")
                ej_cache.clear()
                compile_s, exact = _plan(problem, True)
                times: dict[bool, list[float]] = {False: [], True: []}
                for _ in range(REPEAT):
                    for ex in (False, True):
                        ej_cache.clear()
                        _plan(problem, ex)  # loaded from disk, then warm
                        times[ex].append(_plan(problem, ex)[0])
                a, b = narrow.trajectory, exact.trajectory
                same = a.q.shape == b.q.shape and bool(np.all(a.q == b.q) and np.all(a.t == b.t))
                med = {ex: statistics.median(v) * 1e3 for ex, v in times.items()}
                print(f"{label:28s} {first:9.3f} {choices!s:>7s} {compile_s:8.2f} "
                      f"{med[False]:9.2f} {med[True]:8.2f} {med[False] / med[True]:6.3f} {same}")
        finally:
            if old is None:
                os.environ.pop("MMPLAN_CACHE", None)
            else:
                os.environ["MMPLAN_CACHE"] = old
            ej_cache.clear()


if __name__ == "__main__":
    main()
