"""More obstacles than slots: a library with fewer slots (near obstacles in them) vs one per count.

The obstacle count is a run-time quantity of the compiled functions
(:mod:`mmplan.planners.near_slots`): a scene with more obstacles of a shape type than a
compiled library's slots plans with that library, the obstacles near the robot in its slots,
instead of compiling one with the scene's count. In one run, into an empty temporary cache
folder (``MMPLAN_CACHE``):

1. the paper scenario youbot3r-obstacles-torque compiles its library (2 cylinder and 2
   sphere slots) and is planned;
2. scenes with the paper's obstacles and ``extra`` more cylinders (a few near the path, the
   rest spread away from it) are planned with that library: seconds (compile included, if
   any), whether a compile ran, how often the slots were chosen;
3. the same scenes with a library holding every obstacle (``exact``: compiled here once per
   scene, its seconds reported), then warm plans of both alternated: median compute time,
   the ratio narrow / exact in the same run, and whether the samples are the same to the
   bit;
4. the same for the two path trackers (diffdrive3-track, omni3-impedance) with posts added.

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

from mmplan.planners import get_planner
from mmplan.planners.extended_jacobian import cache as ej_cache
from mmplan.planners.extended_jacobian.planner import ExtendedJacobian
from mmplan.planners.tracking import compiled as track_compiled
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
#: The trackers' scenarios and posts (x, y, radius) added to them (tests/planners/tracking/
#: test_active_slots.py's).
TRACKERS = {
    "diffdrive3-track": [(1.0, 0.6, 0.15), (3.0, -0.55, 0.15), (1.5, 3.0, 0.2)],
    "omni3-impedance": [(1.3, 1.0, 0.02), (-1.0, 0.4, 0.02), (0.2, -1.0, 0.02), (3.0, 3.0, 0.1)],
}


def _problem(extra: list[tuple[float, float]]) -> Problem:
    base = load_scenario(NAME).build()
    added = [Cylinder((float(x), float(y), 0.0), 0.15, 0.4, 0.35) for x, y in extra]
    scene = Scene((*base.scene.obstacles, *added), base.scene.ground)
    settings = base.settings.model_copy(update={"codegen": True, "vibration": False})
    return dataclasses.replace(base, scene=scene, settings=settings)


def _plan(problem: Problem, exact: bool) -> tuple[float, PlanResult]:
    """Compute seconds of one plan and the solution (``exact``: every obstacle in a slot)."""
    method = problem.settings.method
    planner = get_planner(method)()
    original = ExtendedJacobian.__dict__["_prepare"]
    functions = track_compiled.functions
    if exact and method == "extended-jacobian":

        def prepare(cls: type, problem: Problem, guess: bool = False, *_: Any, **__: Any) -> Any:
            return original.__func__(cls, problem, guess, whole=True)

        ExtendedJacobian._prepare = classmethod(prepare)  # type: ignore[method-assign,assignment]
    elif exact:

        def whole(*args: Any, **kwargs: Any) -> Any:
            return functions(*args[:6], exact=True)

        track_compiled.functions = whole
    try:
        start = time.perf_counter()
        sol = planner.plan(problem)
        return time.perf_counter() - start, sol
    finally:
        ExtendedJacobian._prepare = original  # type: ignore[method-assign]
        track_compiled.functions = functions


def _tracker(name: str, extra: list[tuple[float, float, float]]) -> Problem:
    base = load_scenario(name).build()
    added = [Cylinder((x, y, 0.0), r, 0.5) for x, y, r in extra]
    scene = Scene((*base.scene.obstacles, *added), base.scene.ground)
    return dataclasses.replace(base, scene=scene)


def _row(label: str, problem: Problem) -> None:
    """Plan ``problem`` with the narrow library, then compile the exact one; warm pairs."""
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
    print(f"{label:32s} {first:9.3f} {choices!s:>7s} {compile_s:8.2f} "
          f"{med[False]:9.2f} {med[True]:8.2f} {med[False] / med[True]:6.3f} {same}")


def main() -> None:
    old = os.environ.get("MMPLAN_CACHE")
    with tempfile.TemporaryDirectory() as folder:
        os.environ["MMPLAN_CACHE"] = folder
        try:
            ej_cache.clear()
            seconds, sol = _plan(_problem([]), False)
            print(f"paper scene, first compile and plan: {seconds:.2f} s, {sol.status.value}")
            print(f"{'scene':32s} {'narrow s':>9s} {'choices':>7s} {'exact s':>8s} "
                  f"{'narrow ms':>9s} {'exact ms':>8s} {'ratio':>6s} same")
            _row("+3 cylinders near the path", _problem(NEAR))
            _row(f"+{len(NEAR) + len(SPREAD)} cylinders", _problem(NEAR + SPREAD))
            for name, extra in TRACKERS.items():
                seconds, sol = _plan(_tracker(name, []), False)
                print(f"{name}, first compile and plan: {seconds:.2f} s, {sol.status.value}")
                _row(f"{name} +{len(extra)} posts", _tracker(name, extra))
        finally:
            if old is None:
                os.environ.pop("MMPLAN_CACHE", None)
            else:
                os.environ["MMPLAN_CACHE"] = old
            ej_cache.clear()


if __name__ == "__main__":
    main()
