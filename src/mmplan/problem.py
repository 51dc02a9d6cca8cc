"""The planning problem and the settings every method shares (core types).

:class:`Problem` is what a planner solves and what the independent checker judges against;
:class:`PlannerSettings` is the base of every method's settings model. Both live in the core,
below the planners, so that :mod:`mmplan.verify` and :mod:`mmplan.io` need no planner.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from types import UnionType
from typing import Annotated, Any, Union, get_args, get_origin

import numpy as np
from numpy.typing import NDArray
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationInfo,
    field_validator,
    model_validator,
)
from pydantic_core import PydanticCustomError

from mmplan.errors import InputError, require
from mmplan.robot.robot import Robot
from mmplan.scene.scene import Scene
from mmplan.task import Task

#: Called with the fraction done (0..1) while planning; may be None.
Progress = Callable[[float], None] | None


#: Most integration steps a fixed-step planner may be asked for (t_max / dt): the work bound
#: that turns an absurd ``dt`` into an input error instead of a hang or a MemoryError.
MAX_STEPS = 2_000_000


class SettingsModel(BaseModel):
    """Base of every settings model, nested ones included (e.g. a method's sub-settings).

    Unknown keys are errors (``extra="forbid"``), values are validated on construction and
    frozen, and a numeric setting takes numbers only (no booleans or strings).
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    @field_validator("*", mode="before")
    @classmethod
    def _numbers_are_numbers(cls, value: Any, info: ValidationInfo) -> Any:
        """A numeric setting takes numbers only: no ``true`` for 1, no ``"20"`` for 20."""
        if info.field_name is None or info.field_name not in cls.model_fields:
            return value
        allowed = _leaf_types(cls.model_fields[info.field_name].annotation)
        if not allowed or not allowed <= {int, float, type(None)}:
            return value  # not a purely numeric setting: its own validation applies
        items = value if isinstance(value, list | tuple) else [value]
        for item in items:
            if isinstance(item, bool | str):
                raise ValueError(f"expected a number, got {item!r}")
        return value


class PlannerSettings(SettingsModel):
    """Settings every method accepts; a method's model adds its own fields.

    Validation as :class:`SettingsModel`; a method with a fixed step ``dt`` is limited to
    ``t_max / dt <= MAX_STEPS``.
    """

    method: str
    t_max: float = Field(
        120.0,
        gt=0,
        allow_inf_nan=False,
        description="simulated seconds (or iterations budget) before giving up",
    )

    @model_validator(mode="after")
    def _bounded_work(self) -> PlannerSettings:
        """A fixed-step method (a ``dt`` setting) runs at most ``MAX_STEPS`` steps."""
        dt = getattr(self, "dt", None)
        if isinstance(dt, float) and dt > 0 and math.isfinite(self.t_max):
            steps = self.t_max / dt
            if steps > MAX_STEPS:
                raise PydanticCustomError(
                    "scenario",
                    f"t_max / dt = {self.t_max:g} / {dt:g} = {steps:.3g} steps exceeds the limit "
                    f"{MAX_STEPS:.0e}; use a larger dt or a smaller t_max",
                    {"key": "dt"},
                )
        return self


def _leaf_types(annotation: Any) -> set[Any]:
    """The non-container types an annotation admits (``tuple[float, ...] | None`` ->
    {float, NoneType}); an empty set when it holds anything else (models, literals)."""
    origin = get_origin(annotation)
    if origin is None:
        return {annotation} if isinstance(annotation, type) else set()
    if origin is Annotated:
        return _leaf_types(get_args(annotation)[0])
    out: set[Any] = set()
    for arg in get_args(annotation):
        if arg is Ellipsis:
            continue
        leaves = _leaf_types(arg)
        if not leaves:
            return set()
        out |= leaves
    return out if origin in (Union, UnionType, tuple, list) else set()


@dataclass(frozen=True)
class Problem:
    """A fully resolved planning problem: robot (with limits), scene, task, start, settings.

    Checked on construction: each part of its type (the scene any object with ``obstacles``,
    a :class:`Scene` or a stand-in), ``start`` n finite numbers (stored as a float array).

    Raises:
        InputError: a part of another type, or a bad start (the field names it).
    """

    robot: Robot
    scene: Scene
    task: Task
    start: NDArray[np.float64]
    settings: PlannerSettings

    def __post_init__(self) -> None:
        require(self.robot, Robot, "robot", "a Robot (mmplan.get_robot(name))")
        if not hasattr(self.scene, "obstacles"):
            raise InputError("scene", f"expected a Scene, got {type(self.scene).__name__}")
        require(self.task, Task, "task", "a Task (e.g. mmplan.ReachPoint)")
        require(self.settings, PlannerSettings, "settings",
                "planner settings (a PlannerSettings model)")
        object.__setattr__(self, "start", start_array(self.start, self.robot))


def start_array(start: object, robot: Robot) -> NDArray[np.float64]:
    """``start`` as a float array of the robot's n coordinates (a copy); InputError otherwise."""
    try:
        raw = np.asarray(start)
    except (TypeError, ValueError):  # ragged nesting
        raw = np.asarray(None)
    if raw.dtype.kind not in "iuf":  # no strings, booleans, objects, None
        raise InputError("start", f"expected {robot.n} numbers, got {type(start).__name__}"
                         + (f" of {raw.dtype.name}" if raw.ndim else ""))
    values = np.array(raw, dtype=float)
    if values.shape != (robot.n,):
        raise InputError("start", f"expected {robot.n} values {list(robot.coordinates)}, "
                         f"got shape {values.shape}")
    if not np.isfinite(values).all():
        raise InputError("start", f"values must be finite, got {values.tolist()}")
    return values
