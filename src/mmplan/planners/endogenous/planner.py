r"""Endogenous configuration space planner with state bounds ([JaniakTchon]).

The endogenous configuration (lambda, x) -- Fourier coefficients of the platform controls
and the arm joints -- is moved along the theta-iteration of [JaniakTchon] eqs. (14), (20),

.. math::  (\lambda, x) \leftarrow (\lambda, x) - \gamma J^{\#}(\lambda, x)\, e_r(\lambda, x),

explicit Euler in theta with step 1, J^# the Moore-Penrose inverse (Euclidean in
(lambda, x)), e_r the error of the regularized system (eq. (19)) and J its Jacobian (eq. (7));
both come from :class:`~mmplan.planners.endogenous.model.EndogenousModel`. Bounds on platform
coordinates enter as extra states and outputs (eqs. (10)-(13), (18)); bounds on arm joints
(constants of the end point map, which the regularized extra output would pin) through the
saturating coordinate x_k = c + h tanh(xi_k) (:class:`~mmplan.planners.endogenous.output.ArmBox`).

Start: ``problem.start`` is the full q0 in robot order; its platform part is the platform
start q0 and its arm part is the initial arm configuration x0 (the paper's examples, s.III, use
q0 = (20, 0, pi/2, 0) and x0 = (0, 1, pi/2): start = (20, 0, pi/2, 0, 0, 1, pi/2)).
Only ``lambda0`` is a planner setting. ``t_max`` is not used; the budget is
``max_iterations``. The planner has no obstacle model and refuses a scene with obstacles.
The floor (``Scene.ground``): when the plan's arm comes closer than 1 cm to it, the iteration
goes on from there with one more output, active while the arm's blend is below that margin
(:mod:`~mmplan.planners.endogenous.floor`; a plan that keeps clear is the paper's, unchanged);
a plan whose samples still reach below the floor is ``infeasible`` (info
``min_floor_clearance_m``).

Scenario form (docs/conventions.md, docs/endogenous.md)::

    goal: {position: [0, 0, 2], tolerance: 1.0e-4}
    planner:
      method: endogenous
      horizon: 1.0                # T [s]
      basis_terms: [3, 5]         # terms per platform control: 1, sin wt, cos wt, sin 2wt, ...
      lambda0: [-1, 0.5, -0.5, -0.2, 0.1, 0.1, 0.01, 0.01]
      bounds: [{coordinate: psi, min: -1.0472, max: 1.0472}]   # any coordinate, optional

Rate limits (``robot.limits.rates``): the plan is re-timed uniformly, t -> c t with the
smallest c >= 1 that keeps every velocity and acceleration limit at the samples and on the
cubic Hermite interpolant between them (:meth:`~mmplan.time_scaling.rates.RateModel.stretch`;
the interpolant of the stretched samples is the stretched interpolant). For the driftless platform
(dq_p = G(q_p) u) and the arm's blend this is exact: the same path, the same end point, the
horizon c T and the controls u / c (a Fourier series on [0, c T] with coefficients lambda / c).
A plan that would need a horizon above ``t_max``, or an unbounded c (a zero limit on a moving
coordinate), is ``infeasible``; info ``time_scale`` (c) and ``horizon_s`` (c T).

Stop: |e_task| < tolerance (default the goal tolerance) and |bound outputs| < bound_tolerance
(default the same). Status: ``reached``; ``stalled`` (singular Jacobian, or no convergence
within ``max_iterations``: the message says which and gives the smallest singular value or the
error trend); ``diverged`` (non-finite or exploding error); ``infeasible`` (goal met but the
bound outputs stopped decreasing, or the final arm joints leave the robot's joint limits).
Output: the trajectory on [0, T] (RK4 grid, ``steps + 1`` samples, see
:mod:`~mmplan.planners.endogenous.output`), history ``iteration``, ``error_norm``
(|e_r|), ``task_error``, ``min_singular_value`` (of J); info ``iterations``,
``final_error_m``, ``error_norm``, ``bound_residual``, ``min_singular_value`` (over the run),
``max_abs.<coordinate>``,
``bound_overshoot.<coordinate>`` (max excess over the bound / half the bound width, = max|psi| /
bound - 1 for symmetric bounds; negative inside), ``backend`` ("c" or "vm").
"""

from __future__ import annotations

import numpy as np

from mmplan.arrays import Array
from mmplan.errors import InputError
from mmplan.planners.base import Planner, register
from mmplan.planners.endogenous.cache import get_model
from mmplan.planners.endogenous.checks import check_problem
from mmplan.planners.endogenous.floor import FloorOutput, floor_verdict, independent
from mmplan.planners.endogenous.model import EndogenousModel
from mmplan.planners.endogenous.output import ArmBox, build_trajectory, stretched, wrap_arm
from mmplan.planners.endogenous.settings import EndogenousSettings
from mmplan.problem import Problem, Progress
from mmplan.task import ReachPoint
from mmplan.time_scaling.rates import RateModel
from mmplan.trajectory import Solution, Status


@register
class EndogenousPlanner(Planner[EndogenousSettings, ReachPoint]):
    """Jacobian pseudoinverse planner in the endogenous configuration space ([JaniakTchon])."""

    def _solve(
        self, problem: Problem, settings: EndogenousSettings, task: ReachPoint, progress: Progress
    ) -> Solution:
        """Run the theta-iteration ([JaniakTchon] eq. (20)) from (lambda0, x0) to the goal."""
        bounds, lam0 = check_problem(problem, settings)
        robot = problem.robot
        n_p = robot.n_platform
        state_bounds = [b for b in bounds if b.index < n_p]  # extra states, [JaniakTchon] eq. (18)
        box = ArmBox(n_p, robot.n - n_p, [b for b in bounds if b.index >= n_p])
        model = get_model(
            robot,
            settings.horizon,
            settings.basis_terms,
            settings.steps,
            state_bounds,
            settings.sharpness,
            settings.regularizer_weight,
            settings.codegen,
        )
        start = np.asarray(problem.start, float)
        qp0, xi0 = start[:n_p], box.from_x(start[n_p:])
        yd = np.asarray(task.position, float)
        tol = settings.tolerance or task.tolerance
        bound_tol = settings.bound_tolerance or tol
        e0, J0 = _evaluate(model, box, qp0, lam0, xi0, yd)
        if not (np.all(np.isfinite(e0)) and np.all(np.isfinite(J0))):
            raise InputError(
                "planner.lambda0",
                "the initial controls give a non-finite plan (overflow); choose a smaller "
                "lambda0 or horizon",
            )
        s0 = np.linalg.svd(J0, compute_uv=False)
        if s0[-1] < settings.singular_threshold:
            raise InputError(
                "planner.lambda0",
                "dexterity matrix J J^T is singular at the start "
                f"(smallest singular value of J {s0[-1]:.3g}); choose another lambda0 "
                "or start (controls that move the bounded coordinates)",
            )
        floor = FloorOutput.of(robot, problem.scene.ground, start, model.times(), model.horizon,
                               [robot.index(b.coordinate) for b in settings.bounds])
        run = _iterate(model, box, settings, qp0, lam0, xi0, yd, tol, bound_tol, progress)
        if floor is not None and run.status is Status.REACHED and floor.row(box.to_x(run.x)):
            # second phase (.floor): on from the plan that reaches below the floor margin
            again = _iterate(model, box, settings, qp0, run.lam, run.x, yd, tol, bound_tol,
                             None, floor)
            again.errors[:0], again.task_errors[:0] = run.errors, run.task_errors
            again.singular_values[:0] = run.singular_values
            again.min_singular = min(again.min_singular, run.min_singular)
            again.message += " (after lifting the arm off the floor)"
            run = again
        return _result(problem, settings, model, box.to_x(run.x), run)


def _evaluate(
    model: EndogenousModel, box: ArmBox, qp0: Array, lam: Array, xi: Array, yd: Array,
    floor: FloorOutput | None = None,
) -> tuple[Array, Array]:
    """e_r and J ([JaniakTchon] eqs. (19), (7)) in the iteration coordinates (lambda, xi),
    with the floor output's row appended while it is active (:mod:`.floor`)."""
    e, J = model.evaluate(qp0, lam, box.to_x(xi), yd)
    active = floor.row(box.to_x(xi)) if floor is not None else None
    if active is not None:
        row = np.concatenate([np.zeros(model.n_lambda), active[1]])
        if independent(J, row):  # else the other outputs already fix that direction
            e, J = np.append(e, active[0]), np.vstack([J, row])
    J[:, model.n_lambda :] *= box.scale(xi)[None, :]
    return e, J


class _Run:
    """State of the theta-iteration: last finite configuration (lambda, xi) and records."""

    def __init__(self, lam: Array, x: Array) -> None:
        self.lam, self.x = lam, x
        self.e = np.zeros(0)
        self.errors: list[float] = []
        self.task_errors: list[float] = []
        self.singular_values: list[float] = []
        self.min_singular = np.inf
        self.status = Status.STALLED
        self.message = ""


def _iterate(
    model: EndogenousModel,
    box: ArmBox,
    settings: EndogenousSettings,
    qp0: Array,
    lam: Array,
    x: Array,
    yd: Array,
    tol: float,
    bound_tol: float,
    progress: Progress,
    floor: FloorOutput | None = None,
) -> _Run:
    """Theta-iteration [JaniakTchon] eqs. (14), (20) with explicit Euler step 1; sets status
    and message."""
    run = _Run(lam.copy(), x.copy())
    n_lam = model.n_lambda
    first = None
    previous = (run.lam, run.x)
    for it in range(settings.max_iterations + 1):
        e, J = _evaluate(model, box, qp0, run.lam, run.x, yd, floor)
        norm = float(np.linalg.norm(e))
        first = norm if first is None else first
        if not (np.all(np.isfinite(e)) and np.all(np.isfinite(J))) or norm > 1e3 * max(first, 1):
            run.lam, run.x = previous  # keep the last configuration with a finite plan
            run.status = Status.DIVERGED
            run.message = f"error diverged at iteration {it} (|e| = {norm:.3g})"
            return run
        try:
            U, s, Vt = np.linalg.svd(J, full_matrices=False)
        except np.linalg.LinAlgError:  # finite but numerically absurd J
            run.lam, run.x = previous
            run.status = Status.DIVERGED
            run.message = f"SVD of J did not converge at iteration {it} (|e| = {norm:.3g})"
            return run
        task_norm = float(np.linalg.norm(e[:3]))
        run.e = e
        run.errors.append(norm)
        run.task_errors.append(task_norm)
        run.singular_values.append(float(s[-1]))
        run.min_singular = min(run.min_singular, float(s[-1]))
        if task_norm < tol and float(np.linalg.norm(e[3:])) < bound_tol:
            run.status = Status.REACHED
            run.message = f"converged in {it} iterations, |e| = {norm:.3g}"
            return run
        if s[-1] < settings.singular_threshold:
            run.status = Status.STALLED
            run.message = (
                f"singular Jacobian at iteration {it} (smallest singular value "
                f"{s[-1]:.3g}), |e| = {norm:.3g}"
            )
            return run
        if it == settings.max_iterations:
            break
        step = -settings.gamma * (Vt.T @ ((U.T @ e) / s))  # -gamma J^# e
        previous = (run.lam, run.x)
        run.lam = run.lam + step[:n_lam]
        run.x = run.x + step[n_lam:]
        if progress is not None and first > tol:
            progress(float(np.clip(np.log(first / norm) / np.log(first / tol), 0.0, 1.0)))
    run.status, run.message = _budget_status(run, tol, settings.max_iterations)
    return run


def _budget_status(run: _Run, tol: float, iterations: int) -> tuple[Status, str]:
    """Status when the iteration limit ends the run: stalled, or infeasible when the task is
    met but the bound outputs ([JaniakTchon] eq. (18)) stopped decreasing."""
    task, total = run.task_errors[-1], run.errors[-1]
    window = max(2, len(run.errors) // 10)
    bound = np.sqrt(np.maximum(np.square(run.errors) - np.square(run.task_errors), 0.0))
    if task < tol:
        if bound[-1] > 0.9 * bound[-window]:
            return Status.INFEASIBLE, (
                f"goal reached (|e_task| = {task:.3g}) but the bound "
                f"outputs stay at {bound[-1]:.3g} after {iterations} "
                "iterations: the bounds conflict with the goal at this "
                "horizon"
            )
        return Status.STALLED, (
            f"goal reached (|e_task| = {task:.3g}); the bound outputs still "
            f"decrease slowly ({bound[-1]:.3g}) after {iterations} iterations"
        )
    errors = run.errors[-window:]
    trend = "still decreasing" if errors[-1] < 0.5 * errors[0] else "stagnating"
    return Status.STALLED, (
        f"no convergence within {iterations} iterations "
        f"(|e| = {total:.3g}, |e_task| = {task:.3g}, {trend})"
    )


def _result(
    problem: Problem,
    settings: EndogenousSettings,
    model: EndogenousModel,
    x_last: Array,
    run: _Run,
) -> Solution:
    """Trajectory on [0, T] from the last configuration (lambda, x_last), info and history."""
    robot = problem.robot
    start = np.asarray(problem.start, float)
    bounded = [robot.index(b.coordinate) for b in settings.bounds]
    x = wrap_arm(robot, start[robot.n_platform :], x_last, bounded)
    traj = build_trajectory(robot, model, start, run.lam, x)
    q = traj.q
    status, message = run.status, run.message
    limits = robot.limits
    outside = np.flatnonzero((x < limits.joint_min) | (x > limits.joint_max))
    if status is Status.REACHED and outside.size:
        name = robot.arm_coordinates[int(outside[0])]
        status = Status.INFEASIBLE
        message += (
            f"; but arm joint {name} = {x[outside[0]]:.4g} is outside its limits "
            f"[{limits.joint_min[outside[0]]:.4g}, {limits.joint_max[outside[0]]:.4g}]: "
            "add a planner bound on it"
        )
    status, message, floor_info = floor_verdict(problem, q, traj.t, status, message)
    lam, factor = run.lam, 1.0
    if robot.limits.rates.any:
        factor = RateModel.of(robot).stretch(traj.t, traj.q, traj.dq, traj.ddq)
        horizon = factor * model.horizon
        if not np.isfinite(factor) or horizon > settings.t_max:
            if status is not Status.DIVERGED:
                status = Status.INFEASIBLE
            message += (
                f"; the rate limits need a horizon of {horizon:.4g} s (x{factor:.4g}), above "
                f"t_max = {settings.t_max:g} s" if np.isfinite(factor) else
                "; the rate limits cannot be met by any horizon (a zero limit on a moving "
                "coordinate)"
            )  # fmt: skip
        if np.isfinite(factor) and factor > 1.0:
            traj, lam = stretched(traj, factor), run.lam / factor
            message += f"; re-timed x{factor:.4g} to T = {horizon:.4g} s for the rate limits"
    info: dict[str, float | int | str] = {
        "backend": model.backend,
        "time_scale": factor,
        "horizon_s": float(traj.t[-1]),
        "iterations": len(run.errors) - 1,
        "final_error_m": run.task_errors[-1],
        "error_norm": run.errors[-1],
        "bound_residual": float(np.linalg.norm(run.e[3:])) if model.n_b else 0.0,
        "min_singular_value": run.min_singular,
        **floor_info,
    }
    for i, name in enumerate(robot.coordinates):
        info[f"max_abs.{name}"] = float(np.max(np.abs(q[:, i])))
    for b in settings.bounds:
        k = robot.index(b.coordinate)
        half = 0.5 * (b.max - b.min)
        over = max(float(q[:, k].max()) - b.max, b.min - float(q[:, k].min()))
        info[f"bound_overshoot.{b.coordinate}"] = over / half
    history = {
        "iteration": np.arange(len(run.errors), dtype=float),
        "error_norm": np.asarray(run.errors),
        "task_error": np.asarray(run.task_errors),
        "min_singular_value": np.asarray(run.singular_values),
    }
    return Solution(
        status=status,
        trajectory=traj,
        message=message,
        info=info,
        history=history,
        artifacts={"lambda": lam, "x": x},
    )

