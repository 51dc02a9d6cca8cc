"""The two path trackers of [AbdessemedDjebrani] as planners (docs/tracking.md).

* ``pseudoinverse``: weighted-pseudoinverse tracking with joint-limit and obstacle potentials
  in the null space ([AbdessemedDjebrani] section 2; :mod:`.pseudoinverse`);
* ``impedance``: end-effector and platform-pose tracking on an omnidirectional base with a
  virtual impedance around obstacles ([AbdessemedDjebrani] section 3; :mod:`.impedance`).

Both compile one control step and roll it along the path with :func:`.result.track`.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Sequence
from typing import Any

import numpy as np

from mmplan.arrays import Array
from mmplan.compile import codegen as cg
from mmplan.planners.base import Planner, register
from mmplan.planners.near_slots import capped
from mmplan.planners.tracking import compiled
from mmplan.planners.tracking.active import CrowdedError, TrackerSlots
from mmplan.planners.tracking.impedance import VirtualImpedance, platform_distances
from mmplan.planners.tracking.pseudoinverse import WeightedPseudoinverse
from mmplan.planners.tracking.result import track
from mmplan.planners.tracking.rollout import Rollout
from mmplan.planners.tracking.settings import ImpedanceSettings, PseudoinverseSettings
from mmplan.planners.tracking.slots import Slots
from mmplan.problem import Problem, Progress
from mmplan.robot.robot import Robot
from mmplan.scene.obstacle import Obstacle
from mmplan.task import TrackPath
from mmplan.trajectory import Solution


@register
class PseudoinversePlanner(Planner[PseudoinverseSettings, TrackPath]):
    """Weighted-pseudoinverse path tracker with null-space potentials."""

    def _solve(
        self,
        problem: Problem,
        settings: PseudoinverseSettings,
        task: TrackPath,
        progress: Progress,
    ) -> Solution:
        """Track ``task`` from ``problem.start``."""
        return _crowded_or_not(self._track, problem, settings, task, progress)

    @staticmethod
    def _track(
        problem: Problem,
        settings: PseudoinverseSettings,
        task: TrackPath,
        progress: Progress,
        cap: dict[Hashable, int] | None,
    ) -> Solution:
        robot, scene = problem.robot, problem.scene
        slots = _capped(Slots.of(scene.obstacles), cap)
        obstacles, ground = scene.obstacles, scene.ground
        loaded = compiled.functions(
            ("pinv_step", "task_jacobian"), robot, settings, slots, ground,
            lambda: WeightedPseudoinverse(robot, _fit(obstacles, slots), settings, ground, slots)
            .library_functions(), cap is not None,
        )  # fmt: skip
        active = _active(loaded, robot, obstacles, settings.d0, None)
        # without the compiled library the numbers are built in (faster on the VM: 64.7
        # against 86.4 ms a plan with them as parameters, a review's measurement)
        model = WeightedPseudoinverse(
            robot, () if active else obstacles, settings, ground,
            loaded.slots if loaded else None, loaded.functions if loaded else None,
        )  # fmt: skip
        step, backend = model.step, "vm" if loaded is None else "c"

        def reference(t: float) -> Array:
            return np.concatenate([task.position(t), task.velocity(t)])

        return track(
            problem,
            settings,
            task,
            step,
            np.asarray(problem.start, dtype=float),
            reference,
            model.smallest_singular_value,
            progress,
            lambda run: {"weights": [float(v) for v in model.w], "backend": backend,
                         **({"slot_choices": active.choices} if active else {})},
            model.params,
            active,
        )


@register
class ImpedancePlanner(Planner[ImpedanceSettings, TrackPath]):
    """End-effector + platform-pose tracking with virtual impedance."""

    def _solve(
        self,
        problem: Problem,
        settings: ImpedanceSettings,
        task: TrackPath,
        progress: Progress,
    ) -> Solution:
        """Track ``task`` from ``problem.start`` (plus the two impedance filter states)."""
        return _crowded_or_not(self._track, problem, settings, task, progress)

    @staticmethod
    def _track(
        problem: Problem,
        settings: ImpedanceSettings,
        task: TrackPath,
        progress: Progress,
        cap: dict[Hashable, int] | None,
    ) -> Solution:
        robot, scene = problem.robot, problem.scene
        slots = _capped(Slots.of(scene.obstacles), cap)
        obstacles, ground = tuple(scene.obstacles), scene.ground
        loaded = compiled.functions(
            ("impedance_step", "task_matrix", "impedance_force_p"), robot, settings, slots,
            ground,
            lambda: VirtualImpedance(robot, _fit(obstacles, slots), settings, ground, slots)
            .library_functions(), cap is not None,
        )  # fmt: skip
        active = _active(loaded, robot, obstacles, settings.d_max, settings.d_min)
        model = VirtualImpedance(
            robot, () if active else obstacles, settings, ground,
            loaded.slots if loaded else None, loaded.functions if loaded else None,
        )  # fmt: skip
        step, backend = model.step, "vm" if loaded is None else "c"
        state0 = np.concatenate([np.asarray(problem.start, dtype=float), np.zeros(2)])

        def nearest(q: Array) -> Array:  # every obstacle's, when p holds only the near ones
            assert active is not None
            return np.asarray(active.horizontal(q, range(active.count)).min(axis=1))

        def info(run: Rollout) -> dict[str, Any]:
            near = nearest if active else None
            found = platform_distances(model, task, run.t, run.q, near) if scene.obstacles else {}
            return {**found, "backend": backend,
                    **({"slot_choices": active.choices} if active else {})}

        return track(
            problem,
            settings,
            task,
            step,
            state0,
            lambda t: model.reference(task, t),
            model.smallest_singular_value,
            progress,
            info,
            model.params,
            active,
        )


def _crowded_or_not(
    track: Callable[[Problem, Any, TrackPath, Progress, dict[Hashable, int] | None], Solution],
    problem: Problem,
    settings: Any,
    task: TrackPath,
    progress: Progress,
) -> Solution:
    """``track`` with a library of at most :data:`~mmplan.planners.near_slots.SLOT_CAP` slots
    a kind (the family's too); where more obstacles of a kind come near the robot at once than
    its slots, again with more of that kind (at most the scene's count: then every obstacle
    is held)."""
    cap: dict[Hashable, int] | None = None
    while True:
        try:
            return track(problem, settings, task, progress, cap)
        except CrowdedError as crowd:
            cap = crowd.grown(cap or {})
            cg.notice(f"{crowd}: a step with {cap[crowd.kind]} of them")


def _capped(slots: Slots | None, cap: dict[Hashable, int] | None) -> Slots | None:
    """``slots`` with at most ``cap``'s count of a kind (:func:`mmplan.planners.near_slots.
    capped`; None: the cap of a first try)."""
    if slots is None:
        return None
    return Slots(capped(slots.kinds, cap or {}))  # type: ignore[arg-type]


def _fit(obstacles: Sequence[Obstacle], slots: Slots | None) -> tuple[Obstacle, ...]:
    """The obstacles a model built for ``slots`` packs: all when they fit, else none (its
    library's functions take the obstacles as parameters; the choice fills them, :mod:`.active`;
    a scene of more obstacles than a capped library's slots raised "do not fit")."""
    fits = slots is None or slots.accepts(obstacles)
    return tuple(obstacles) if fits else ()


def _active(
    loaded: compiled.Loaded | None,
    robot: Robot,
    obstacles: Sequence[Obstacle],
    influence: float,
    platform: float | None,
) -> TrackerSlots | None:
    """The choice of the near obstacles when the library has fewer slots of a kind than the
    scene has obstacles (:mod:`.active`), else None."""
    if loaded is None or loaded.slots.accepts(obstacles):
        return None
    return TrackerSlots(robot, loaded.slots, obstacles, influence, platform)
