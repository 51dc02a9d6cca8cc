r"""Robot: a platform and an arm as one symbolic kinematic tree, with compiled functions.

Everything planners need in loops is compiled once into CasADi ``Function`` objects
(:attr:`Robot.functions`) from the symbolic tree; the NumPy-facing methods wrap them.

Symbols (all expressions in the generalized coordinates q (n,), platform part first):

* k(q) end-effector position (3,), J = dk/dq (3, n), J_a its arm columns (3, n_a);
* A(q) Pfaffian matrix (h, n), N(q) basis of ker A (n, n - h), B(q) actuation (n, n - h);
* M(q) (n, n), c(q, dq) (n,) from :mod:`mmplan.robot.dynamics`;
* manipulability mu(q) = sqrt(det(J_a J_a^T)) (Yoshikawa; [PajakPajak] eq. (5)), with J_a the
  arm's position Jacobian, or its full 6-row tool Jacobian for ``EndEffector(manipulability=
  "pose")`` ([Nagatani]);
* actuator efforts tau = (N^T B)^{-1} N^T (M ddq + c) ([PajakPajak] eq. (20)): the efforts that
  realise ddq when the constraint forces A^T lambda are eliminated (N^T A^T = 0).
"""

from __future__ import annotations

import copy
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

from mmplan.arrays import Array
from mmplan.errors import InputError, ModelError, require
from mmplan.robot import compiled as robot_compiled
from mmplan.robot import dynamics
from mmplan.robot.bases import Platform
from mmplan.robot.limits import Limits
from mmplan.robot.tree import Body, Joint, KinematicTree


@dataclass(frozen=True)
class CollisionSphere:
    """A collision sphere fixed to a body: ``center`` in the body frame [m], ``radius`` [m].

    A radius of 0 is a collision point ([PajakPajak] and [Pajak] discretize links into points).
    """

    body: str
    center: tuple[float, float, float]
    radius: float = 0.0


@dataclass(frozen=True)
class EndEffector:
    """End-effector point: ``offset`` [m] in the frame of ``body``.

    ``manipulability`` selects the arm Jacobian of the measure mu = sqrt(det(J_a J_a^T)):
    ``"position"`` (3, n_arm), the measure of [PajakPajak] and [Pajak] for a point task, or
    ``"pose"`` (6, n_arm: linear and angular velocity of the tool), [Nagatani]'s measure for a
    6-dof arm.
    """

    body: str
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    manipulability: str = "position"

    def __post_init__(self) -> None:
        if self.manipulability not in ("position", "pose"):
            raise ModelError(
                f"EndEffector.manipulability: {self.manipulability!r} not position/pose"
            )


@dataclass
class Symbols:
    """Symbolic expressions of a robot (CasADi SX), for planners that derive further."""

    q: ca.SX
    dq: ca.SX
    ddq: ca.SX
    transforms: dict[str, ca.SX]
    ee_position: ca.SX
    ee_rotation: ca.SX
    jacobian: ca.SX
    jacobian_arm: ca.SX
    pfaffian: ca.SX
    null_basis: ca.SX
    actuation: ca.SX
    mass_matrix: ca.SX
    bias: ca.SX
    manipulability: ca.SX
    collision_points: ca.SX
    tau: ca.SX = field(default_factory=lambda: ca.SX())
    #: Planned end-effector acceleration J ddq + (dJ/dt) dq (3,) [m/s^2].
    ee_acceleration: ca.SX = field(default_factory=lambda: ca.SX())


#: Robot.functions: name -> (the Symbols fields of its inputs, of its output).
_FUNCTIONS: dict[str, tuple[tuple[str, ...], str]] = {
    "ee_position": (("q",), "ee_position"),
    "jacobian": (("q",), "jacobian"),
    "pfaffian": (("q",), "pfaffian"),
    "null_basis": (("q",), "null_basis"),
    "actuation": (("q",), "actuation"),
    "mass_matrix": (("q",), "mass_matrix"),
    "bias": (("q", "dq"), "bias"),
    "manipulability": (("q",), "manipulability"),
    "collision_points": (("q",), "collision_points"),
    "tau": (("q", "dq", "ddq"), "tau"),
    "ee_acceleration": (("q", "dq", "ddq"), "ee_acceleration"),
}


class _Functions(Mapping[str, ca.Function]):
    """:attr:`Robot.functions`: each CasADi function made when first asked for (making all ten
    costs ~5 ms a robot, the bias forces and efforts most; a command needs a few) and kept in
    ``made`` (the robot's shared store: copies share them)."""

    def __init__(self, robot: Robot, made: dict[str, ca.Function]) -> None:
        self._robot = robot
        self._made = made

    def __getitem__(self, name: str) -> ca.Function:
        fn = self._made.get(name)
        if fn is None:
            inputs, output = _FUNCTIONS[name]  # KeyError for an unknown name, as a dict
            s = self._robot.symbols
            fn = ca.Function(name, [getattr(s, i) for i in inputs], [getattr(s, output)])
            self._made[name] = fn
        return fn

    def __iter__(self) -> Iterator[str]:
        return iter(_FUNCTIONS)

    def __len__(self) -> int:
        return len(_FUNCTIONS)


class Robot:
    """A mobile manipulator: platform + arm, kinematics, Pfaffian constraints and dynamics.

    Args:
        name: Robot name (registry key).
        platform: Platform kind, contributing the first coordinates.
        arm_bodies, arm_joints: The arm's bodies and joints; the arm root's parent is
            ``"platform"``. Every non-fixed arm joint adds one arm coordinate.
        end_effector: End-effector point.
        limits: Default joint and actuator limits.
        collision: Collision spheres (points) on the platform and the links.
        friction: Optional joint friction per coordinate name.
        description: One paragraph for ``mmplan robots``.
    """

    def __init__(
        self,
        name: str,
        platform: Platform,
        arm_bodies: Sequence[Body],
        arm_joints: Sequence[Joint],
        end_effector: EndEffector,
        limits: Limits,
        collision: Sequence[CollisionSphere] = (),
        friction: Mapping[str, dynamics.Friction] | None = None,
        description: str = "",
    ) -> None:
        for key, value, kind in (("name", name, str), ("platform", platform, Platform),
                                 ("end_effector", end_effector, EndEffector),
                                 ("limits", limits, Limits), ("description", description, str)):
            require(value, kind, key, f"a {kind.__name__}")
        self.name = name
        self.description = description
        self.platform = platform
        p_bodies, p_joints = platform.bodies_and_joints()
        self.tree = KinematicTree([*p_bodies, *arm_bodies], [*p_joints, *arm_joints])
        self.platform_coordinates = tuple(platform.coordinates)
        self.arm_coordinates = tuple(
            c for c in self.tree.coordinates if c not in platform.coordinates
        )
        self.coordinates: tuple[str, ...] = self.platform_coordinates + self.arm_coordinates
        if set(self.coordinates) != set(self.tree.coordinates):
            raise ModelError(f"{name}: platform coordinates {platform.coordinates} not in tree")
        self.n = len(self.coordinates)
        self.n_platform = len(self.platform_coordinates)
        self.h = platform.n_constraints
        self.arm_indices = tuple(range(self.n_platform, self.n))
        self.actuators: tuple[str, ...] = tuple(platform.actuators) + self.arm_coordinates
        self.end_effector = end_effector
        self.collision = tuple(collision)
        self.friction = dict(friction or {})
        for body in {end_effector.body} | {c.body for c in self.collision}:
            if body not in self.tree.bodies:
                raise ModelError(f"{name}: unknown body {body!r}")
        self.limits = limits
        self._check_limits(limits)
        self._shared: dict[str, Any] = {}

    # ------------------------------------------------------------------ limits
    def _check_limits(self, limits: Limits) -> None:
        n_arm, n_act = len(self.arm_coordinates), len(self.actuators)
        for key, arr, size in (
            ("limits.joints.min", limits.joint_min, n_arm),
            ("limits.joints.max", limits.joint_max, n_arm),
            ("limits.torque.min", limits.torque_min, n_act),
            ("limits.torque.max", limits.torque_max, n_act),
        ):
            if np.shape(arr) != (size,):
                raise InputError(
                    key, f"expected {size} values for {self.name}, got {np.shape(arr)}"
                )
            if np.isnan(arr).any():
                raise InputError(key, "contains NaN")
        for key, lo, hi in (
            ("limits.joints", limits.joint_min, limits.joint_max),
            ("limits.torque", limits.torque_min, limits.torque_max),
        ):
            for side, values, wrong in (("min", lo, np.inf), ("max", hi, -np.inf)):
                empty = np.flatnonzero(np.asarray(values) == wrong)
                if empty.size:
                    raise InputError(f"{key}.{side}[{int(empty[0])}]",
                                     f"a {side} of {wrong} admits no value")
            bad = np.flatnonzero(np.asarray(lo) > np.asarray(hi))
            if bad.size:
                i = int(bad[0])
                raise InputError(f"{key}.min[{i}]", f"min {lo[i]} > max {hi[i]}")

    def with_limits(self, limits: Limits) -> Robot:
        """A copy with other limits, sharing the symbolic model and compiled functions."""
        self._check_limits(limits)
        other = copy.copy(self)
        other.limits = limits
        return other

    # ------------------------------------------------------------------ symbols
    @property
    def symbols(self) -> Symbols:
        """Symbolic model, built on first use and shared by copies."""
        if "symbols" not in self._shared:
            self._shared["symbols"] = self._build_symbols()
        sym: Symbols = self._shared["symbols"]
        return sym

    def _build_symbols(self) -> Symbols:
        n = self.n
        q, dq, ddq = ca.SX.sym("q", n), ca.SX.sym("dq", n), ca.SX.sym("ddq", n)
        values = {name: q[i] for i, name in enumerate(self.coordinates)}
        T = self.tree.world_transforms(values)
        T_ee = T[self.end_effector.body]
        ee = T_ee[:3, :3] @ ca.DM(self.end_effector.offset) + T_ee[:3, 3]
        J = ca.jacobian(ee, q)
        J_a = J[:, list(self.arm_indices)]
        qp = q[: self.n_platform]
        n_arm = n - self.n_platform
        A = ca.horzcat(self.platform.pfaffian(qp), ca.SX.zeros(self.h, n_arm))
        N = ca.diagcat(self.platform.null_basis(qp), ca.SX.eye(n_arm))
        B = ca.diagcat(self.platform.actuation(qp), ca.SX.eye(n_arm))
        M = dynamics.mass_matrix(self.tree, q, T)
        V = dynamics.potential_energy(self.tree, T)
        friction = {self.coordinates.index(k): f for k, f in self.friction.items()}
        c = dynamics.bias_forces(M, V, q, dq, friction)
        J_mu = J_a
        if self.end_effector.manipulability == "pose":
            J_w = dynamics.angular_jacobian(T_ee[:3, :3], q)[:, list(self.arm_indices)]
            J_mu = ca.vertcat(J_a, J_w)
        mu = ca.sqrt(ca.fmax(ca.det(J_mu @ J_mu.T), 0))  # det >= 0 up to rounding: no NaN
        points = [T[s.body][:3, :3] @ ca.DM(s.center) + T[s.body][:3, 3] for s in self.collision]
        P = ca.horzcat(*points) if points else ca.SX(3, 0)
        tau = ca.solve(N.T @ B, N.T @ (M @ ddq + c))
        acc = J @ ddq + ca.jtimes(J @ dq, q, dq)
        return Symbols(q, dq, ddq, T, ee, T_ee[:3, :3], J, J_a, A, N, B, M, c, mu, P, tau, acc)

    @property
    def functions(self) -> Mapping[str, ca.Function]:
        """Compiled CasADi functions, by name (each built on first use, shared by copies).

        ``ee_position(q)``, ``jacobian(q)``, ``pfaffian(q)``, ``null_basis(q)``,
        ``actuation(q)``, ``mass_matrix(q)``, ``bias(q, dq)``, ``manipulability(q)``,
        ``collision_points(q)``, ``tau(q, dq, ddq)``.
        """
        made: dict[str, ca.Function] = self._shared.setdefault("functions", {})
        return _Functions(self, made)  # a view: the store holds no reference to the robot

    # ------------------------------------------------------------------ numpy API
    def _q(self, q: ArrayLike, name: str = "q") -> Array:
        arr = np.asarray(q, dtype=float)
        if arr.shape != (self.n,):
            raise InputError(
                name, f"expected {self.n} values {self.coordinates}, got shape {arr.shape}"
            )
        return arr

    def compiled(self) -> robot_compiled.Natives | None:
        """This model's functions compiled to C when their library is on disk
        (:mod:`mmplan.robot.compiled`; looked up once per model), else None."""
        return robot_compiled.natives(self, self._shared)

    def _call(self, fn: str, *args: Array) -> Array:
        """``functions[fn]`` at one point: compiled when the robot's library is on disk
        (:mod:`mmplan.robot.compiled`: no symbolic model needed, the same numbers), else on
        the virtual machine."""
        natives = self.compiled() if fn in robot_compiled.NAMES else None
        if natives is not None:
            try:
                return natives.call(fn, *args)
            except (AttributeError, RuntimeError, ValueError):  # a symbol missing from the file
                pass
        return np.asarray(self.functions[fn](*args), dtype=float)

    def ee_position(self, q: ArrayLike) -> Array:
        """End-effector position k(q) [m], (3,)."""
        return self._call("ee_position", self._q(q)).reshape(3)

    def jacobian(self, q: ArrayLike) -> Array:
        """J(q) = dk/dq, (3, n)."""
        return self._call("jacobian", self._q(q))

    def pfaffian(self, q: ArrayLike) -> Array:
        """A(q), (h, n)."""
        return self._call("pfaffian", self._q(q)).reshape(self.h, self.n)

    def null_basis(self, q: ArrayLike) -> Array:
        """N(q), (n, n - h), columns spanning ker A(q)."""
        return self._call("null_basis", self._q(q))

    def actuation(self, q: ArrayLike) -> Array:
        """B(q), (n, n_act)."""
        return self._call("actuation", self._q(q))

    def mass_matrix(self, q: ArrayLike) -> Array:
        """M(q), (n, n)."""
        return self._call("mass_matrix", self._q(q))

    def bias(self, q: ArrayLike, dq: ArrayLike) -> Array:
        """c(q, dq): Coriolis, centrifugal, gravity, friction, (n,)."""
        return self._call("bias", self._q(q), self._q(dq, "dq")).reshape(self.n)

    def manipulability(self, q: ArrayLike) -> float:
        """mu(q) = sqrt(det(J_a J_a^T))."""
        return float(self._call("manipulability", self._q(q)).item())

    def collision_points(self, q: ArrayLike) -> Array:
        """World positions of the collision spheres' centres, (P, 3) (one row a point)."""
        P = self._call("collision_points", self._q(q)).reshape(3, len(self.collision))
        return np.ascontiguousarray(P.T)

    def collision_points_at(self, Q: ArrayLike) -> Array:
        """The collision spheres' centres at N states (rows of Q), (N, P, 3): the compiled
        functions mapped over the states when their library is on disk, else the virtual
        machine's mapped function."""
        states = np.ascontiguousarray(np.atleast_2d(np.asarray(Q, dtype=float)))
        N, P = len(states), len(self.collision)
        if P == 0 or N == 0:
            return np.zeros((N, P, 3))
        natives = self.compiled()
        if natives is not None:
            return np.asarray(natives.many("collision_points", states), float).reshape(N, P, 3)
        raw = np.asarray(self.functions["collision_points"].map(N)(states.T), dtype=float)
        return np.ascontiguousarray(raw.T.reshape(N, P, 3))  # (3, N P), a block of P a state

    @cached_property
    def collision_radii(self) -> Array:
        """Radii of the collision spheres, (P,)."""
        return np.array([s.radius for s in self.collision], dtype=float)

    def actuator_efforts(self, q: ArrayLike, dq: ArrayLike, ddq: ArrayLike) -> Array:
        """tau = (N^T B)^-1 N^T (M ddq + c) ([PajakPajak] eq. (20)), (n_act,)."""
        out = self._call("tau", self._q(q), self._q(dq, "dq"), self._q(ddq, "ddq"))
        return out.reshape(len(self.actuators))

    def body_positions(self, q: ArrayLike) -> dict[str, Array]:
        """World origin (3,) of every body (for drawing)."""
        if "bodies_fn" not in self._shared:
            s = self.symbols
            names = [b for b in self.tree.bodies if not b.startswith("_")]
            outs = [s.transforms[b][:3, 3] for b in names]
            self._shared["bodies_fn"] = (names, ca.Function("bodies", [s.q], [ca.horzcat(*outs)]))
        names, fn = self._shared["bodies_fn"]
        P = np.asarray(fn(self._q(q)), dtype=float)
        return {name: P[:, i] for i, name in enumerate(names)}

    def index(self, coordinate: str) -> int:
        """Position of ``coordinate`` in q."""
        try:
            return self.coordinates.index(coordinate)
        except ValueError:
            raise InputError(
                "coordinate", f"unknown {coordinate!r}; known: {self.coordinates}"
            ) from None

    def __repr__(self) -> str:
        return f"Robot({self.name!r}, n={self.n}, h={self.h}, coordinates={self.coordinates})"
