"""Symbolic rigid transforms (CasADi SX) used to build kinematic trees.

All functions accept floats or CasADi ``SX`` scalars and return ``SX`` matrices, so that a
tree's forward kinematics is one symbolic expression in the generalized coordinates.
"""

from __future__ import annotations

from collections.abc import Sequence

import casadi as ca

Scalar = float | ca.SX


def rot_x(a: Scalar) -> ca.SX:
    """Rotation by ``a`` [rad] about the x axis, (3, 3)."""
    c, s = ca.cos(a), ca.sin(a)
    return ca.vertcat(ca.horzcat(1, 0, 0), ca.horzcat(0, c, -s), ca.horzcat(0, s, c))


def rot_y(a: Scalar) -> ca.SX:
    """Rotation by ``a`` [rad] about the y axis, (3, 3)."""
    c, s = ca.cos(a), ca.sin(a)
    return ca.vertcat(ca.horzcat(c, 0, s), ca.horzcat(0, 1, 0), ca.horzcat(-s, 0, c))


def rot_z(a: Scalar) -> ca.SX:
    """Rotation by ``a`` [rad] about the z axis, (3, 3)."""
    c, s = ca.cos(a), ca.sin(a)
    return ca.vertcat(ca.horzcat(c, -s, 0), ca.horzcat(s, c, 0), ca.horzcat(0, 0, 1))


def rot_rpy(rpy: Sequence[float]) -> ca.SX:
    """URDF convention: R = Rz(yaw) Ry(pitch) Rx(roll), (3, 3)."""
    return rot_z(rpy[2]) @ rot_y(rpy[1]) @ rot_x(rpy[0])


def rot_axis(axis: Sequence[float], a: Scalar) -> ca.SX:
    """Rodrigues rotation by ``a`` about the unit vector ``axis``, (3, 3).

    Axis-aligned axes use the exact elementary rotations so that expressions stay small.
    """
    ax = [float(v) for v in axis]
    for i, rot in enumerate((rot_x, rot_y, rot_z)):
        unit = [0.0, 0.0, 0.0]
        unit[i] = 1.0
        if ax == unit:
            return rot(a)
        unit[i] = -1.0
        if ax == unit:
            return rot(-a)
    k = ca.SX(ax)
    kx = skew(k)
    return ca.SX.eye(3) + ca.sin(a) * kx + (1 - ca.cos(a)) * (kx @ kx)


def skew(v: ca.SX) -> ca.SX:
    """Cross-product matrix [v]x of a 3-vector, (3, 3)."""
    return ca.vertcat(
        ca.horzcat(0, -v[2], v[1]), ca.horzcat(v[2], 0, -v[0]), ca.horzcat(-v[1], v[0], 0)
    )


def homogeneous(rotation: ca.SX, translation: ca.SX | Sequence[Scalar]) -> ca.SX:
    """4x4 homogeneous transform from a rotation (3, 3) and a translation (3,)."""
    t = ca.vertcat(*translation) if not isinstance(translation, ca.SX) else translation
    top = ca.horzcat(rotation, t)
    return ca.vertcat(top, ca.horzcat(0, 0, 0, 1))


def translation(t: Sequence[Scalar]) -> ca.SX:
    """Pure translation, (4, 4)."""
    return homogeneous(ca.SX.eye(3), t)
