r"""The run-time parameter vector p of the extended-Jacobian generator (compile once per robot).

Everything about a scene that the generator needs is a number in p, so one compiled function
serves every scene of a robot model and a set of obstacle shape types:

.. code-block:: text

    p = [p_f (3), Lambda_P, Lambda_V, Lambda_II,          goal and gains
         h, delta_h,                                       floor z = h and its delta
         (c (3), a (3), cos psi, sin psi, delta) per slot, superellipsoid slots, by shape type
         theta_ref,                                        heading term (only if the robot has one)
         sigma (n_a), S_F (n_a x (n_a - 1))]               column partition (only if parametric)

* A shape type is the pair of exponents (e1, e2) of the superellipsoid model (box, cylinder,
  sphere, ...): the exponents decide the operations (powers by multiplications,
  :func:`mmplan.scene.smooth_model.power_sym`), centre, semi-axes, yaw and delta are numbers;
  the yaw psi as its cosine and sine (the compiled step's culling tests read every slot five
  times a step: their sin and cos took 2 % of youBot-3r's chunks, measured).
  Each type has a fixed number of slots (:func:`slots_for`: the scene's count rounded up to a
  multiple of :data:`SLOT_STEP`); an unused slot lies :data:`PARKED` m away with delta = 0,
  so the exact bounding-box culling (:mod:`~mmplan.planners.extended_jacobian.obstacles`)
  never evaluates it and its kappa is exactly 0 anyway.
* The floor: no floor (``ground`` None) is a plane :data:`PARKED` m below the robot.
* The partition R = platform + one arm joint (the papers' youBots, TIAGo): sigma is the
  one-hot choice of that arm joint and S_F selects the others (F) in robot order
  (:func:`mmplan.planners.extended_jacobian.structure.selected_transversality`); other
  partitions are built into the function (``n_select`` 0).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from mmplan.arrays import Array
from mmplan.planners.extended_jacobian.criterion import Criterion, Partition
from mmplan.planners.extended_jacobian.structure import partition_selection

#: Slots of a shape type come in multiples of this.
SLOT_STEP = 2
#: Distance [m] of a parked (unused) slot or of an absent floor.
PARKED = 1e3
#: Numbers per superellipsoid slot: centre (3), semi-axes (3), cos yaw, sin yaw, delta.
SLOT_SIZE = 9
#: Index of the floor block [h, delta] in p.
FLOOR = 6
#: Goal, gains and floor.
HEAD = 8

Shape = tuple[float, float]  # exponents (e1, e2)


def shape_of(model: Any) -> Shape:
    """The shape type (e1, e2) of a superellipsoid model."""
    return (float(model.exponents[0]), float(model.exponents[1]))


def put_slot(p: Array, at: int, model: Any, delta: float) -> None:
    """Write an obstacle (its superellipsoid model and delta) into the slot at ``at`` of p."""
    p[at : at + 3] = model.center
    p[at + 3 : at + 6] = model.semi_axes
    yaw = float(getattr(model, "yaw", 0.0))
    p[at + 6 : at + 8] = math.cos(yaw), math.sin(yaw)  # libm's, as the C code's
    p[at + 8] = float(delta)


def park_slot(p: Array, at: int) -> None:
    """Mark the slot at ``at`` of p unused (module docstring)."""
    p[at : at + SLOT_SIZE] = (PARKED, PARKED, PARKED, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0)


def slots_for(exponents: Sequence[Shape], step: int = SLOT_STEP) -> tuple[tuple[Shape, int], ...]:
    """Shape types and slot counts for obstacles with these exponents (sorted by type)."""
    counts: dict[Shape, int] = {}
    for e in exponents:
        key = (float(e[0]), float(e[1]))
        counts[key] = counts.get(key, 0) + 1
    return tuple((e, step * math.ceil(k / step)) for e, k in sorted(counts.items()))


def merge_slots(
    a: tuple[tuple[Shape, int], ...], b: tuple[tuple[Shape, int], ...]
) -> tuple[tuple[Shape, int], ...]:
    """Per shape type the larger slot count of a and b."""
    out = dict(a)
    for e, k in b:
        out[e] = max(out.get(e, 0), k)
    return tuple(sorted(out.items()))


def layout_of(
    robot: Any, crit: Criterion, slots: Sequence[tuple[Shape, int]] | Sequence[Any]
) -> ParameterLayout:
    """The layout of a generator built from ``crit`` with these obstacle slots ((exponents,
    count) pairs, or obstacles (``ObstacleTerm``) whose shape types get :func:`slots_for`)."""
    if slots and hasattr(slots[0], "model"):
        slots = slots_for([ob.model.exponents for ob in slots])  # type: ignore[union-attr]
    n_arm = len(robot.arm_indices) if crit.sel.numel() else 0
    return ParameterLayout(
        tuple(slots), bool(crit.theta.numel()), n_arm, robot.n_platform, crit.choices
    )


@dataclass(frozen=True)
class ParameterLayout:
    """Where each number of p lies (module docstring).

    Attributes:
        slots: (exponents, count) per shape type.
        heading: The robot has a heading term (its theta_ref is a parameter).
        n_arm: Arm joints of a parametric partition (0: partition built in).
        n_platform: Platform coordinates (the partition's fixed part).
        choices: Arm joints (robot indices) a parametric partition may put in R.
    """

    slots: tuple[tuple[Shape, int], ...] = ()
    heading: bool = False
    n_arm: int = 0
    n_platform: int = 0
    choices: tuple[int, ...] = ()

    @property
    def n_slots(self) -> int:
        return sum(k for _, k in self.slots)

    @property
    def heading_index(self) -> int:
        return HEAD + SLOT_SIZE * self.n_slots

    @property
    def select_index(self) -> int:
        return self.heading_index + int(self.heading)

    @property
    def n_select(self) -> int:
        return self.n_arm * self.n_arm

    @property
    def size(self) -> int:
        return self.select_index + self.n_select

    def slot_offsets(self) -> list[tuple[Shape, int]]:
        """(exponents, offset in p) of every slot, in order."""
        out, at = [], HEAD
        for e, k in self.slots:
            for _ in range(k):
                out.append((e, at))
                at += SLOT_SIZE
        return out

    def starts(self) -> dict[Shape, list[int]]:
        """Offsets in p of the slots of each shape type, in order."""
        out: dict[Shape, list[int]] = {}
        for e, at in self.slot_offsets():
            out.setdefault(e, []).append(at)
        return out

    def accepts(self, exponents: Sequence[Shape]) -> bool:
        """The slots hold obstacles with these exponents."""
        need = dict(slots_for(exponents, 1))
        have = dict(self.slots)
        return all(have.get(e, 0) >= k for e, k in need.items())

    def selection(self, partition: Partition) -> Array:
        """[sigma; vec(S_F)] of a partition R = platform + one arm joint (module docstring)."""
        return partition_selection(self.n_platform, self.n_arm, partition)

    def supports(self, partition: Partition) -> bool:
        """The partition is a value of p (no new function needed)."""
        extra = set(partition.R) - set(range(self.n_platform))
        if not self.n_arm or not extra <= set(self.choices):
            return False
        try:
            self.selection(partition)
        except ValueError:
            return False
        return True

    def pack(
        self,
        p_f: Array,
        gains: Sequence[float] | Array,
        obstacles: Sequence[tuple[Any, float]] = (),
        ground: tuple[float, float] | None = None,
        partition: Partition | None = None,
        heading: float | None = None,
    ) -> Array:
        """p for a goal, gains, obstacles ((model, delta) pairs: an ``ObstacleTerm``), the
        floor (h, delta) or None, the partition and the heading reference.

        Raises:
            ValueError: more obstacles of a shape type than slots, or a partition the
                layout cannot take (the caller builds another function).
        """
        p = np.zeros(self.size)
        p[:3] = np.asarray(p_f, dtype=float)
        p[3:6] = np.asarray(gains, dtype=float)
        p[FLOOR : FLOOR + 2] = (-PARKED, 0.0) if ground is None else ground
        free = self.starts()
        for at in (a for starts in free.values() for a in starts):
            park_slot(p, at)
        for model, delta in obstacles:
            e = shape_of(model)
            if not free.get(e):
                raise ValueError(f"no free slot for an obstacle with exponents {e}")
            put_slot(p, free[e].pop(0), model, delta)
        if self.heading:
            p[self.heading_index] = 0.0 if heading is None else heading
        if self.n_arm:
            if partition is None:
                raise ValueError("the layout needs the partition")
            p[self.select_index :] = self.selection(partition)
        return p

    def retarget(self, p: Array, partition: Partition) -> Array:
        """p of another function of the same robot and slots (the same numbers up to the
        partition block, which is last) for this layout and ``partition``."""
        head = np.asarray(p, dtype=float)[: self.select_index]
        return np.concatenate([head, self.selection(partition)]) if self.n_arm else head

    def select_sym(self, p: ca.SX) -> tuple[ca.SX, ca.SX]:
        """sigma (n_a,) and S_F (n_a, n_a - 1) as parts of the symbol p."""
        at, n_a = self.select_index, self.n_arm
        sigma = p[at : at + n_a]
        S_F = ca.reshape(p[at + n_a : at + n_a * n_a], n_a, n_a - 1)
        return sigma, S_F
