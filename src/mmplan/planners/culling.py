"""Which obstacles a plan's model holds: those near the region the robot can reach.

Used by the planner template (:meth:`mmplan.planners.base.Planner.plan`) for every method:

1. *Region.* The robot's extent E [m] around a body point b (its start collision points and
   end effector over sampled arm configurations, the platform at the start; a rigid move of
   the platform keeps every point within E of the moved b). b travels from its start to the
   task (the goal point, samples of a path, a segment's ends), and the plan may detour, so
   the region is the polyline b -> task points grown by
   ``E + max obstacle reach + CULL_MARGIN + DETOUR * length`` (:func:`region`).
2. *Cull.* Obstacles farther than that from the polyline are left out of the model
   (:func:`mmplan.scene.cull.near_path`); at least the nearest one is always kept (a method
   without an obstacle model still sees that the scene has obstacles).
3. *Verify.* After planning, every left-out obstacle is measured against the trajectory's
   collision spheres at every sample; one that comes within its reach (its own
   ``influence``, else 0, plus the method's obstacle distances and ``CULL_MARGIN``) is put
   back and the problem planned again (:func:`came_near`); after ``MAX_REPLANS`` re-plans
   the whole scene is used.
"""

from __future__ import annotations

import math
import re
from dataclasses import replace
from functools import lru_cache

import casadi as ca
import numpy as np

from mmplan.arrays import Array
from mmplan.compile.model_cache import ModelCache
from mmplan.errors import InputError
from mmplan.problem import Problem
from mmplan.robot.robot import Robot
from mmplan.scene.cull import near_path, near_points
from mmplan.scene.scene import Scene
from mmplan.task import DrawSegment, ReachPoint, TrackPath
from mmplan.trajectory import Trajectory

#: Distance [m] added to every obstacle's reach: beyond the neighbourhoods the methods use.
CULL_MARGIN = 1.0
#: Settings (any method) that are distances [m] at which the method reacts to an obstacle;
#: their sum is added to every obstacle's reach.
OBSTACLE_DISTANCE_SETTINGS = ("obstacle_margin", "influence", "d0", "d_max")
#: Allowed detour [m per m of the straight polyline] of the body point.
DETOUR = 0.5
#: Most obstacles a plan may model (those near the region): beyond it the model's size
#: (measured with far spheres before culling: 300 spheres 42 s and 0.6 GB, 1000 spheres
#: 60 s and 4.1 GB, 2000 spheres 136 s and 8 GB) turns a scenario into a hang.
MAX_NEAR_OBSTACLES = 500
#: Re-plans with put-back obstacles before the whole scene is used.
MAX_REPLANS = 2
#: Arm configurations sampled for the robot's extent (the start is one more).
EXTENT_SAMPLES = 32


def reaches(problem: Problem) -> tuple[float, ...]:
    """Per obstacle, the distance [m] within which it may change the plan."""
    settings = problem.settings
    own = sum(float(getattr(settings, name)) for name in OBSTACLE_DISTANCE_SETTINGS
              if isinstance(getattr(settings, name, None), int | float))
    return tuple(float(o.influence or 0.0) + own + CULL_MARGIN for o in problem.scene.obstacles)


def extent(robot: Robot, start: Array) -> tuple[Array, float]:
    """(b, E): the centroid b (3,) of the start's collision points and end effector, and the
    largest distance E [m] of a collision sphere's surface or the end effector from b over
    the start and ``EXTENT_SAMPLES`` arm configurations within the joint limits."""
    lo = np.where(np.isfinite(robot.limits.joint_min), robot.limits.joint_min, -math.pi)
    hi = np.where(np.isfinite(robot.limits.joint_max), robot.limits.joint_max, math.pi)
    arm = list(robot.arm_indices)
    Q = np.repeat(np.asarray(start, dtype=float)[:, None], EXTENT_SAMPLES + 1, axis=1)
    Q[arm, 1:] = (lo + (hi - lo) * spread(EXTENT_SAMPLES, len(arm))).T

    # every configuration in one mapped call of the robot's functions (a loop of 34 calls
    # cost 7-8 ms a plan, a quarter of a warm youbot-3r plan); the mapped functions are kept
    # per robot model (building them cost 2-5 ms a plan)
    K, P = Q.shape[1], len(robot.collision)
    natives = robot.compiled()
    if natives is not None:  # compiled, one point a call: no symbolic model needed
        # C order as the mapped call's: NumPy's reductions below sum in memory order (a
        # transposed view gave a centroid one ulp off)
        ee = np.ascontiguousarray(natives.many("ee_position", Q.T).T)  # (3, K)
        pts = np.zeros((3, K, P))
        if P:
            flat = natives.many("collision_points", Q.T).reshape(K, P, 3)
            pts = np.ascontiguousarray(flat.transpose(2, 0, 1))
    else:
        ee_map, points_map = _MAPS.get_or_build(robot.symbols, K, lambda: _maps(robot, K))
        ee = np.asarray(ee_map(Q), dtype=float).reshape(3, K)
        pts = np.zeros((3, K, 0))
        if points_map is not None:
            pts = np.asarray(points_map(Q), dtype=float).reshape(3, K, P)
    allpts = np.concatenate([pts, ee[:, :, None]], axis=2)  # (3, K, P + 1)
    radii = np.append(robot.collision_radii, 0.0)
    b = allpts[:, 0, :].mean(axis=1)
    size = float(np.max(np.linalg.norm(allpts - b[:, None, None], axis=0) + radii[None, :]))
    return b, size


_MAPS: ModelCache[tuple[ca.Function, ca.Function | None]] = ModelCache(8)


def _maps(robot: Robot, K: int) -> tuple[ca.Function, ca.Function | None]:
    """The end effector and the collision points mapped over K configurations."""
    points = robot.functions["collision_points"].map(K) if robot.collision else None
    return robot.functions["ee_position"].map(K), points


@lru_cache(maxsize=16)
def spread(count: int, dim: int) -> Array:
    """``count`` fixed points spread evenly over the unit cube of ``dim`` dimensions (count,
    dim): the additive recurrence of the generalised golden ratio (a low-discrepancy
    sequence, Roberts 2018), u_k = frac(1/2 + k (1/phi, 1/phi^2, ...)) with phi^(dim+1) =
    phi + 1. The same points every call, without a random generator (importing NumPy's
    costs about 8 ms a process); kept per (count, dim), read-only."""
    points = _spread(count, dim)
    points.flags.writeable = False
    return points


def _spread(count: int, dim: int) -> Array:
    if dim == 0:
        return np.zeros((count, 0))
    phi = 2.0
    for _ in range(30):  # Newton on phi^(d+1) - phi - 1 from above: converges monotonically
        phi -= (phi ** (dim + 1) - phi - 1.0) / ((dim + 1) * phi**dim - 1.0)
    alpha = (1.0 / phi) ** np.arange(1, dim + 1)
    k = np.arange(1, count + 1)[:, None]
    return np.asarray((0.5 + k * alpha[None, :]) % 1.0, dtype=float)


def region(problem: Problem) -> tuple[Array, float] | None:
    """(polyline (K, 3), radius [m]) holding everything the plan may touch; None when the task
    has no known extent (nothing is culled)."""
    task = problem.task
    if isinstance(task, ReachPoint):
        targets = [np.asarray(task.position, dtype=float)]
    elif isinstance(task, TrackPath):
        targets = [np.asarray(task.position(float(t)), dtype=float)
                   for t in np.linspace(0.0, float(task.duration), 33)]
    elif isinstance(task, DrawSegment):
        targets = [np.asarray(task.start, dtype=float), np.asarray(task.end, dtype=float)]
    else:
        return None
    b, size = extent(problem.robot, np.asarray(problem.start, dtype=float))
    path = np.vstack([b[None, :], *[t[None, :] for t in targets]])
    length = float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))
    reach = max(reaches(problem), default=CULL_MARGIN)
    return path, size + reach + DETOUR * length


def kept_obstacles(problem: Problem) -> tuple[int, ...] | None:
    """Indices of the obstacles the model holds (scenario order); None: all of them.

    Raises:
        InputError: more than ``MAX_NEAR_OBSTACLES`` obstacles near the region.
    """
    scene = problem.scene
    if not isinstance(scene, Scene) or not scene.obstacles:
        return None
    found = region(problem)
    if found is None:
        kept = tuple(range(len(scene.obstacles)))
        radius = math.inf
    else:
        path, radius = found
        kept = near_path(scene.obstacles, path, radius)
        if not kept:  # the nearest one: a method without an obstacle model still refuses
            d = [float(np.min(o.distance(path))) for o in scene.obstacles]
            kept = (int(np.argmin(d)),)
    if len(kept) > MAX_NEAR_OBSTACLES:
        where = "in the scene" if math.isinf(radius) else (
            f"within {radius:.3g} m of the region the robot can reach")
        raise InputError("obstacles", f"{len(kept)} obstacles {where}; a plan models at most "
                         f"{MAX_NEAR_OBSTACLES} (leave out or merge obstacles)")
    return None if len(kept) == len(scene.obstacles) else kept


def with_obstacles(problem: Problem, kept: tuple[int, ...]) -> Problem:
    """``problem`` whose scene holds only the obstacles ``kept``."""
    scene = problem.scene
    return replace(problem, scene=replace(scene, obstacles=tuple(scene.obstacles[i]
                                                                 for i in kept)))


def came_near(problem: Problem, kept: tuple[int, ...], trajectory: Trajectory) -> tuple[int, ...]:
    """Indices of left-out obstacles that come within their reach of the trajectory's
    collision spheres (any sample)."""
    robot, scene = problem.robot, problem.scene
    left_out = [i for i in range(len(scene.obstacles)) if i not in set(kept)]
    if not left_out or not robot.collision:
        return ()
    q = trajectory.q[np.isfinite(trajectory.q).all(axis=1)]
    if len(q) == 0:
        return ()
    fn = robot.functions["collision_points"].map(len(q))
    pts = np.asarray(fn(np.ascontiguousarray(q.T)), dtype=float).T  # (N * P, 3)
    radii = np.tile(robot.collision_radii, len(q))
    reach = reaches(problem)
    near = near_points([scene.obstacles[i] for i in left_out], pts, radii,
                       [reach[i] for i in left_out])
    return tuple(left_out[j] for j in near)


def renumbered(err: InputError, kept: tuple[int, ...]) -> InputError:
    """``err`` raised on the culled scene, its obstacle numbers those of the whole scene."""

    def fix(text: str) -> str:
        def sub(m: re.Match[str]) -> str:
            j = int(m.group(2))
            return f"{m.group(1)}{kept[j] if j < len(kept) else j}"

        return re.sub(r"(obstacles\[|obstacle )(\d+)", sub, text)

    out = type(err).__new__(type(err))
    InputError.__init__(out, fix(err.field), fix(err.problem))
    out.__dict__.update({k: v for k, v in err.__dict__.items() if k not in ("field", "problem")})
    return out
