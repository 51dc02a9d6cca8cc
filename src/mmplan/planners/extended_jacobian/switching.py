"""Column-partition switches along an extended-Jacobian run (same optimum, [PajakPajak] eq. (11)).

The zero set of g does not depend on the partition R/F of Jc = [J; A], but Jc_R^-1 does: a
partition chosen at the start can turn singular along the run. Two triggers, checked every
``cond_every`` steps (:mod:`~mmplan.planners.extended_jacobian.rollout`):

* cond(E) above ``switch_cond`` (1e5): any partition at least 10 times better conditioned
  (the papers' youBots; their runs never switch);
* cond(Jc_R) above :data:`JR_RATIO` times its value where the partition was taken: any
  partition at least twice better. On TIAGo, R = platform + arm_2 turns singular when the
  end effector swings beside the platform centre (a differential drive cannot move it
  sideways there): measured cond(Jc_R) 32 at the start, 202 at a blow-up (t = 7.6 s) while
  cond(E), checked once a second, read 4e4 < 1e5. Over the reproduction's youBot runs and
  the random youbot-3r set the ratio stays below 1.41, so this trigger never fires there.

A switch mid-run builds the new generator on CasADi's virtual machine (no C build).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from mmplan import linalg
from mmplan.arrays import Array
from mmplan.planners.extended_jacobian.criterion import Partition, repartition, stacked_jacobian
from mmplan.planners.extended_jacobian.functions import GeneratorFunctions
from mmplan.robot.robot import Robot

#: cond(Jc_R) growth (against its value where the partition was taken) that asks for a switch.
JR_RATIO = 3.0
#: Improvement a cond(Jc_R)-triggered switch needs (cond(E)-triggered: 10x, repartition).
JR_FACTOR = 0.5


@dataclass
class PartitionSwitch:
    """The partitions of one run and the generator builder for a new one.

    Args:
        robot: The robot.
        build: Partition -> its generator functions.
        partitions: The partitions so far (the current one last).
        switch_cond: cond(E) threshold of the first trigger.
    """

    robot: Robot
    build: Callable[[Partition], GeneratorFunctions]
    partitions: list[Partition]
    switch_cond: float
    _ref: list[float] = field(default_factory=list)

    def __post_init__(self) -> None:
        self._ref = []

    def _cond_jr(self, q: Array, E: Array | None = None) -> float:
        """cond(Jc_R) at q; from the rows of E = [de_I/dq; A] when given: its first three rows
        are the Jacobian of the task error k(q) - p_f, i.e. J, and its last h rows are A, so
        Jc = [J; A] comes without evaluating the robot's functions (two calls on CasADi's
        virtual machine a chunk: 3 ms of a 40 ms youbot3r-obstacles-torque plan)."""
        if E is None:
            Jc = stacked_jacobian(self.robot, q)
        else:
            h = self.robot.h
            Jc = np.vstack([E[:3], E[len(E) - h :]]) if h else E[:3]
        return linalg.cond(Jc[:, list(self.partitions[-1].R)])

    def wanted(self, q: Array, cond_E: float, E: Array | None = None) -> float | None:
        """The improvement factor a switch at q needs, None when no trigger fires (``E``: the
        generator's E at q, when the caller has it)."""
        if cond_E > self.switch_cond:
            return 0.1
        if not self._ref:
            return None  # the reference is set by :meth:`start`
        jr = self._cond_jr(q, E)
        return JR_FACTOR if jr > JR_RATIO * self._ref[-1] else None

    def wants(self, q: Array, cond_E: float, E: Array | None = None) -> bool:
        """A switch is wanted at q (:meth:`wanted` fires)."""
        return self.wanted(q, cond_E, E) is not None

    def start(self, q0: Array) -> None:
        """Take cond(Jc_R) at the run's start as the reference."""
        self._ref = [self._cond_jr(q0)]

    def __call__(self, q: Array, factor: float = 0.1) -> GeneratorFunctions | None:
        """The generator of a partition ``factor`` times better conditioned at q, if any."""
        other = repartition(self.robot, q, self.partitions[-1], factor)
        if other is None:
            return None
        self.partitions.append(other)
        self._ref.append(self._cond_jr(q))
        return self.build(other)
