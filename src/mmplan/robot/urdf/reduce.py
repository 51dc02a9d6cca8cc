"""Which URDF joints move, and the model with every other joint merged as fixed.

Only the joints on the chain from the URDF root to the end-effector frame move, plus the
platform's wheel joints; every other joint (casters, suspension, head, a second arm, fingers)
is held at its ``locked`` value, else at zero, else at the limit nearest zero, and merged into
its parent body by Pinocchio's ``buildReducedModel`` (inertias, frames and collision geometry
move with it).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from mmplan.arrays import Array
from mmplan.errors import InputError
from mmplan.robot.urdf.parse import close_matches, joint_type, pinocchio
from mmplan.robot.urdf.spec import Locked


@dataclass(frozen=True)
class Reduction:
    """A URDF model reduced to its moving joints.

    Attributes:
        model: Pinocchio model of the moving joints (held joints merged as fixed).
        geometry: Its collision GeometryModel (None when not loaded).
        full_model: The model as parsed.
        chain: Moving joints on the chain to the end effector, root first.
        wheels: Moving wheel joints, as given.
        held: Value of every held joint by name [rad or m].
        reference: Full-model configuration holding those values (nq,).
    """

    model: Any
    geometry: Any
    full_model: Any
    chain: tuple[str, ...]
    wheels: tuple[str, ...]
    held: dict[str, float]
    reference: Array


def _ancestors(model: Any, jid: int) -> list[int]:
    out = []
    while jid != 0:
        out.append(jid)
        jid = int(model.parents[jid])
    return out[::-1]


def _joint_id(model: Any, name: str, key: str, what: str) -> int:
    jid = int(model.getJointId(name)) if model.existJointName(name) else 0
    if jid == 0:
        names = [str(n) for n in model.names[1:]]
        raise InputError(key, f"unknown {what} {name!r}" + close_matches(name, names, "joints"))
    return jid


def _limits(model: Any, jid: int) -> tuple[float, float]:
    i = int(model.idx_qs[jid])
    return float(model.lowerPositionLimit[i]), float(model.upperPositionLimit[i])


def end_effector_joint(model: Any, frame: str, key: str) -> int:
    """Joint that carries ``frame`` (a URDF link or joint frame).

    Raises:
        InputError: unknown frame (with close matches), or a frame fixed to the URDF root.
    """
    if not model.existFrame(frame):
        names = list(dict.fromkeys(str(f.name) for f in model.frames[1:]))
        raise InputError(key, f"unknown frame {frame!r}" + close_matches(frame, names, "frames"))
    jid = int(model.frames[model.getFrameId(frame)].parentJoint)
    if jid == 0:
        raise InputError(key, f"frame {frame!r} is fixed to the URDF root: no joint moves it")
    return jid


def held_value(model: Any, jid: int, locked: Locked, key: str) -> float:
    """Value a held joint keeps: its locked value, else 0, else the limit nearest 0.

    Raises:
        InputError: a locked value outside the joint's limits.
    """
    name = str(model.names[jid])
    kind = joint_type(model.joints[jid])
    if kind == "continuous":
        return locked.values.get(name, 0.0)
    lo, hi = _limits(model, jid)
    if name in locked.values:
        value = locked.values[name]
        if not lo - 1e-12 <= value <= hi + 1e-12:
            raise InputError(f"{key}.{name}", f"locked value {value:g} outside the joint's "
                             f"limits [{lo:g}, {hi:g}]")
        return value
    return float(np.clip(0.0, lo, hi))


def reduce_model(
    model: Any,
    geometry: Any,
    *,
    end_effector: str,
    wheels: Sequence[str],
    locked: Locked,
    key: str = "robot",
) -> Reduction:
    """Keep the chain to ``end_effector`` and the ``wheels`` moving; hold every other joint.

    Raises:
        InputError: naming the joint or frame: unknown end-effector frame, unknown or
            non-continuous wheel joint, a wheel carried by a moving joint or carrying the end
            effector, an unknown or wheel joint in ``locked``, a locked value outside limits.
    """
    pin = pinocchio()
    ee_joint = end_effector_joint(model, end_effector, f"{key}.end_effector")
    chain_ids = _ancestors(model, ee_joint)
    wheel_ids = []
    for i, name in enumerate(wheels):
        jid = _joint_id(model, name, f"{key}.platform.wheels[{i}]", "wheel joint")
        kind = joint_type(model.joints[jid])
        if kind != "continuous":
            raise InputError(f"{key}.platform.wheels[{i}]", f"wheel joint {name!r} is {kind}, "
                             "not continuous")
        if jid in chain_ids:
            raise InputError(f"{key}.platform.wheels[{i}]", f"wheel joint {name!r} carries the "
                             f"end effector {end_effector!r}")
        wheel_ids.append(jid)
    for name in locked.values:
        jid = _joint_id(model, name, f"{key}.locked.{name}", "joint")
        if jid in wheel_ids:
            raise InputError(f"{key}.locked.{name}", "a wheel joint of the platform cannot be "
                             "locked")
        if model.joints[jid].nv != 1:
            raise InputError(f"{key}.locked.{name}", f"joint type "
                             f"{model.joints[jid].shortname()} cannot be locked at one value")
    chain = [j for j in chain_ids if str(model.names[j]) not in locked.values]
    if not chain:
        raise InputError(f"{key}.end_effector", f"every joint moving {end_effector!r} is locked")
    moving = set(chain) | set(wheel_ids)
    for i, jid in enumerate(wheel_ids):
        carriers = [j for j in _ancestors(model, jid)[:-1] if j in moving]
        if carriers:
            raise InputError(f"{key}.platform.wheels[{i}]", f"wheel joint {wheels[i]!r} is "
                             f"carried by the moving joint {model.names[carriers[-1]]!r}")

    reference = np.asarray(pin.neutral(model), dtype=float).copy()
    held: dict[str, float] = {}
    to_lock = []
    for jid in range(1, model.njoints):
        if jid in moving:
            continue
        to_lock.append(jid)
        joint = model.joints[jid]
        if joint.nv != 1:
            continue  # planar/floating/spherical joints stay at their neutral value
        value = held_value(model, jid, locked, f"{key}.locked")
        held[str(model.names[jid])] = value
        i = int(model.idx_qs[jid])
        if joint.nq == 2:  # continuous: (cos, sin)
            reference[i : i + 2] = (np.cos(value), np.sin(value))
        else:
            reference[i] = value
    if geometry is None:
        reduced, reduced_geometry = pin.buildReducedModel(model, to_lock, reference), None
    else:
        reduced, reduced_geometry = pin.buildReducedModel(model, geometry, to_lock, reference)
    return Reduction(
        reduced,
        reduced_geometry,
        model,
        tuple(str(model.names[j]) for j in chain),
        tuple(str(model.names[j]) for j in wheel_ids),
        held,
        reference,
    )
