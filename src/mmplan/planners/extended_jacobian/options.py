"""Numerical options of one extended-Jacobian rollout, derived from the settings in one place.

Used by the step decision, the compiled chunks, the feedback mode and the rollout loop; it
sits below all of them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mmplan.arrays import Array, BoolArray
from mmplan.planners.extended_jacobian.settings import ExtendedJacobianSettings
from mmplan.planners.extended_jacobian.torque import virtual_control as vc
from mmplan.robot.robot import Robot
from mmplan.time_scaling.rates import RateModel


@dataclass(frozen=True)
class RolloutOptions:
    """Numerical options of one rollout, derived from the planner settings by
    :meth:`from_settings` (the one place; no setting is restated here with a default).

    ``stall_fraction``, ``cond_every``, ``switch_cond`` and ``max_switches`` are internal
    constants, not settings. A window without progress is one whose error fell by less than
    ``stall_progress`` and by less than ``stall_fraction`` of its value at the window's start
    (:meth:`stalled`): a run converging slowly (obstacle damping near the goal) is no stall.
    """

    dt: float
    t_max: float
    stop_error: float
    gains: tuple[float, float, float]
    torque_control: bool
    zone: tuple[Array, Array]
    limits: tuple[Array, Array]
    eps_growth: vc.Growth
    rho: float
    rho_min: float
    rho_max: float
    budget_perturbation: bool
    stall_window: float
    stall_progress: float
    escape: bool
    escape_gain: float
    escape_time: float
    max_escapes: int
    cond_limit: float
    rates: RateModel | None = None
    coordinates: tuple[str, ...] = ()
    stall_fraction: float = 0.1
    cond_every: int = 50
    switch_cond: float = 1e5
    max_switches: int = 4

    def stalled(self, before: Array | float, now: Array | float) -> BoolArray:
        """No progress from error ``before`` to ``now`` over one window (class docstring),
        elementwise (a 0-d array for scalars).

        Measured on TIAGo (random set): with the absolute test alone, runs 3.6 mm from the
        goal, converging under the obstacle damping, counted as stalled and were thrown
        0.7 m off by escape pushes, three times in 40 s (timeout at 2 mm).
        """
        before = np.asarray(before)
        progress = before - np.asarray(now)
        small = progress < self.stall_fraction * before
        out: BoolArray = (progress < self.stall_progress) & small
        return out

    @classmethod
    def from_settings(
        cls, settings: ExtendedJacobianSettings, robot: Robot, tolerance: float
    ) -> RolloutOptions:
        """The options of a plan with ``settings`` for ``robot`` to a goal ``tolerance`` [m].

        Torque control is on when the robot has torque limits, unless the settings say
        otherwise (``virtual_control.enabled``); the run stops at half the tolerance.
        ``rates`` holds the robot's velocity and acceleration limits (None when it has none),
        ``coordinates`` the names for messages.
        """
        vcs = settings.virtual_control
        limits = robot.limits
        torque_control = limits.has_torque_limits if vcs.enabled is None else vcs.enabled
        return cls(
            dt=settings.dt,
            t_max=settings.t_max,
            stop_error=0.5 * tolerance,
            gains=(settings.lambda_p, settings.lambda_v, settings.lambda_ii),
            torque_control=torque_control,
            zone=vc.safety_zone(limits.torque_min, limits.torque_max, vcs.eps_tau),
            limits=(limits.torque_min, limits.torque_max),
            eps_growth=vc.Growth(vcs.growth),
            rho=vcs.rho,
            rho_min=vcs.rho_min,
            rho_max=vcs.rho_max,
            budget_perturbation=vcs.budget_perturbation,
            stall_window=settings.stall_window,
            stall_progress=settings.stall_progress,
            escape=settings.escape,
            escape_gain=settings.escape_gain,
            escape_time=settings.escape_time,
            max_escapes=settings.max_escapes,
            cond_limit=settings.cond_limit,
            rates=_rates(robot),
            coordinates=robot.coordinates,
        )


def _rates(robot: Robot) -> RateModel | None:
    """The robot's rate limits, None when none is finite on its coordinates."""
    if not robot.limits.rates.any:
        return None
    model = RateModel.of(robot)
    return model if model.any else None
