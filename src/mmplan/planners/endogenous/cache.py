"""Reuse of compiled endogenous-planner models within one process ([JaniakTchon]).

Building an :class:`~mmplan.planners.endogenous.model.EndogenousModel` (symbolic build,
C library load) costs about 10 ms; repeated plans of the same shape reuse it.
"""

from __future__ import annotations

from collections.abc import Sequence

from mmplan.compile.model_cache import ModelCache
from mmplan.planners.endogenous.model import EndogenousModel, ResolvedBound
from mmplan.robot.robot import Robot

#: Models built in this process, by robot model and shape (see :func:`get_model`).
_MODELS: ModelCache[EndogenousModel] = ModelCache(32)


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
    process; at most 32 models are kept (least recently used dropped first).
    """
    key = (
        float(horizon),
        tuple(basis_terms),
        int(steps),
        tuple(bounds),
        float(sharpness),
        float(regularizer_weight),
        bool(codegen),
    )
    return _MODELS.get_or_build(  # the symbolic model is shared by copies with other limits
        robot.symbols,
        key,
        lambda: EndogenousModel(
            robot, horizon, basis_terms, steps, bounds, sharpness, regularizer_weight, codegen
        ),
    )
