"""Test-only planner ``test-eta``: drives dq = N(q) eta for a constant eta (never shipped).

Integrates the kinematics with RK4 at step ``dt`` and stops as soon as the task error is
below the tolerance (status ``reached``) or at ``t_max`` (status ``timeout``); ddq by
differentiating dq along the samples, tau the model's efforts of that motion (a plan of a
robot with torque limits carries them). Honest by construction: the status is the measured
error at the last sample. ``sleep_s`` makes the run slow (to exercise the progress bar).
"""

from __future__ import annotations

import time
from typing import Literal

import numpy as np
from pydantic import Field

from mmplan.planners.base import Planner, register
from mmplan.problem import PlannerSettings, Problem, Progress
from mmplan.task import Task
from mmplan.trajectory import Solution, Status, Trajectory

METHOD = "test-eta"


class EtaSettings(PlannerSettings):
    """Constant auxiliary velocity eta (n - h) and the RK4 step."""

    method: Literal["test-eta"] = METHOD
    eta: list[float]
    dt: float = Field(0.01, gt=0, allow_inf_nan=False)
    sleep_s: float = Field(0.0, ge=0)


@register
class EtaPlanner(Planner[EtaSettings, Task]):
    """dq = N(q) eta, RK4."""

    def _solve(
        self, problem: Problem, s: EtaSettings, task: Task, progress: Progress
    ) -> Solution:
        robot = problem.robot
        eta = np.asarray(s.eta, dtype=float)

        def f(q: np.ndarray) -> np.ndarray:
            return robot.null_basis(q) @ eta

        steps = int(np.ceil(s.t_max / s.dt))
        qs = [np.asarray(problem.start, dtype=float)]
        status = Status.TIMEOUT
        for k in range(steps + 1):
            ee = robot.ee_position(qs[-1])
            if task.errors(np.array([k * s.dt]), ee[None, :])[0] < task.tolerance:
                status = Status.REACHED
                break
            if k == steps:
                break
            q = qs[-1]
            k1 = f(q)
            k2 = f(q + 0.5 * s.dt * k1)
            k3 = f(q + 0.5 * s.dt * k2)
            k4 = f(q + s.dt * k3)
            qs.append(q + s.dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4))
            if progress is not None:
                progress(k / steps)
            if s.sleep_s:
                time.sleep(s.sleep_s / steps)
        q_arr = np.array(qs)
        t = np.arange(len(qs)) * s.dt
        dq = np.array([f(q) for q in q_arr])
        ddq = np.gradient(dq, t, axis=0) if len(t) > 1 else np.zeros_like(dq)
        ee_arr = np.array([robot.ee_position(q) for q in q_arr])
        tau = np.array([robot.actuator_efforts(*x) for x in zip(q_arr, dq, ddq, strict=True)])
        traj = Trajectory(robot.coordinates, t, q_arr, dq, ddq, ee_arr, robot.actuators, tau)
        return Solution(status, traj, message=f"{status.value} after {len(t)} samples",
                        info={"steps": len(t) - 1, "eta_norm": float(np.linalg.norm(eta))},
                        history={"error": np.linalg.norm(ee_arr - ee_arr[-1], axis=1)})
