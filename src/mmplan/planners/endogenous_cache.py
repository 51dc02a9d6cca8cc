"""Reuse of compiled endogenous-planner models within one process (paper 002).

Building an :class:`~mmplan.planners.endogenous_model.EndogenousModel` (symbolic build,
C library load) costs about 10 ms; repeated plans of the same shape reuse it.
"""

from __future__ import annotations

import weakref
from collections.abc import Sequence

from mmplan.planners.endogenous_model import EndogenousModel, ResolvedBound
from mmplan.robot.robot import Robot, Symbols

#: Models built in this process, by robot model and shape (see :func:`get_model`).
_MODELS: dict[tuple[object, ...], tuple[weakref.ref[Symbols], EndogenousModel]] = {}
_MAX_MODELS = 32


def get_model(
    robot: Robot,
    horizon: float,
    basis_terms: Sequence[int],
    steps: int,
    bounds: Sequence[ResolvedBound],
    sharpness: float,
    regularizer_weight: float,
    codegen: bool = False,
) -> EndogenousModel:
    """An :class:`EndogenousModel`, reused when the same robot model and shape come again.

    Saves the symbolic build and the library load (about 10 ms) on repeated plans in one
    process; at most 32 models are kept (oldest dropped first).
    """
    symbols = robot.symbols
    key = (
        id(symbols),
        float(horizon),
        tuple(basis_terms),
        int(steps),
        tuple(bounds),
        float(sharpness),
        float(regularizer_weight),
        bool(codegen),
    )
    found = _MODELS.get(key)
    if found is not None and found[0]() is symbols:
        return found[1]
    model = EndogenousModel(
        robot, horizon, basis_terms, steps, bounds, sharpness, regularizer_weight, codegen
    )
    if len(_MODELS) >= _MAX_MODELS:
        _MODELS.pop(next(iter(_MODELS)))
    _MODELS[key] = (weakref.ref(symbols), model)
    return model
