r"""More obstacles than a tracker's compiled slots: the near ones in the slots (speed).

A tracker's compiled step (:mod:`.compiled`) holds a number of slots per obstacle kind
(:mod:`.slots`). A scene with more obstacles of a kind than a library of the step's family
has slots runs that library, the obstacles near the robot in its slots
(:mod:`mmplan.planners.near_slots` chooses them; the rollout checks the obstacles left out,
:mod:`.rollout`). Exact, because every obstacle term of the trackers is exactly 0 beyond a
reach (``if_else``), and both measure exact signed distances (:mod:`mmplan.scene.parametric`,
the same geometry as the shapes' NumPy ``distance``):

* pseudoinverse: the barrier potential of a collision sphere, 0 for a sphere whose distance
  minus radius is at least the obstacle's influence (``d0`` or its own); the clearance of
  the stop rule is the smallest such distance, so an obstacle left out (farther than its
  influence) never decides it;
* impedance: the force on the platform centre, 0 where its horizontal distance to the
  obstacle (at the obstacle's middle height) is at least the reach max(d_max, d_min); the
  spheres' clearance decides only the collision stop (an obstacle left out is at a distance
  above the margin).

So an obstacle counts as mattering (gap <= 0) where the smallest distance of a sphere minus
its radius and the influence is <= 0, or (impedance) the platform's horizontal distance minus
the reach is. The samples equal those of a library holding every obstacle to the bit in the
tests; the pseudoinverse's may differ by rounding (7.5e-15 in q, a review's probes) where the
first slot holds another obstacle: the derivative of its potential builds the sphere centres
inside the first slot's expressions (docs/tracking.md).
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence
from typing import Any

import casadi as ca
import numpy as np

from mmplan.arrays import Array
from mmplan.planners.near_slots import CrowdedError, NearSlots
from mmplan.planners.tracking.slots import Slots
from mmplan.scene import parametric

__all__ = ["CrowdedError", "TrackerSlots"]


class TrackerSlots(NearSlots):
    """Which of a scene's obstacles a tracker's parameter vector holds (module docstring).

    Args:
        robot: The robot.
        slots: The library's slots (fewer of some kind than the scene's obstacles).
        obstacles: The scene's obstacles (each of a parametric kind).
        influence: The influence for obstacles without their own (and parked slots).
        platform: The impedance's force reach: None for the pseudoinverse (the spheres'
            potentials), else ``d_min`` (the reach is max(influence, d_min)).
    """

    def __init__(
        self,
        robot: Any,
        slots: Slots,
        obstacles: Sequence[Any],
        influence: float,
        platform: float | None = None,
    ) -> None:
        kinds = [parametric.kind_of(ob) for ob in obstacles]
        super().__init__(robot, kinds, dict(slots.kinds))
        self.slots, self.obstacles, self.default = slots, list(obstacles), float(influence)
        own = [ob.influence if ob.influence is not None else influence for ob in obstacles]
        self.influence = np.array(own, dtype=float)
        self.platform = platform
        self.middle = np.array([
            float(parametric.middle_z(k, ca.DM(parametric.geometry(ob, k))))
            for k, ob in zip(kinds, obstacles, strict=True) if k is not None
        ])  # fmt: skip

    def gaps(self, C: Array, Q: Array, which: Sequence[int]) -> Array:
        """gap per state and obstacle ``which`` (module docstring), (M, W)."""
        M, P = C.shape[:2]
        out = np.full((M, len(which)), np.inf)
        flat = C.reshape(-1, 3)
        for j, i in enumerate(which):
            ob = self.obstacles[i]
            if P:
                d = np.asarray(ob.distance(flat), dtype=float).reshape(M, P) - self.radii
                reach = 0.0 if self.platform is not None else self.influence[i]
                out[:, j] = d.min(axis=1) - reach
            if self.platform is not None:
                reach = max(self.influence[i], self.platform + 1e-9)
                out[:, j] = np.minimum(out[:, j], self.horizontal(Q, [i])[:, 0] - reach)
        return out

    def horizontal(self, Q: Array, which: Sequence[int]) -> Array:
        """Distance [m] of the platform centre (x, y of the states Q (M, n)) to the obstacles
        ``which`` at their middle height (the impedance force's), (M, W)."""
        Q = np.atleast_2d(Q)
        out = np.empty((len(Q), len(which)))
        for j, i in enumerate(which):
            at = np.column_stack([Q[:, 0], Q[:, 1], np.full(len(Q), self.middle[i])])
            out[:, j] = np.asarray(self.obstacles[i].distance(at), dtype=float)
        return out

    def write(self, p: Array, chosen: dict[Hashable, list[int]]) -> Array:
        """The parameter vector of the chosen obstacles (:meth:`Slots.pack`)."""
        picked = sorted(i for mine in chosen.values() for i in mine)
        return self.slots.pack([self.obstacles[i] for i in picked], self.default)
