r"""Numeric inverse kinematics of a robot's arm, batched over many targets and base poses.

For a general arm (no closed form, e.g. TIAGo's 7 joints) the arm joints :math:`q_a` that put
the end-effector point (the robot's ``ee_position``, offset included) at a target position,
and its frame's orientation at a target, with the platform at a given planar pose
(x, y, theta), are found by Levenberg-Marquardt iteration on the residual

.. math::
    e(q_a) = \big[\,p_d - p(q_a);\ e_R(q_a)\,\big], \qquad
    q_a \leftarrow \Pi\big(q_a - (J^T J + \lambda I)^{-1} J^T e\big),\quad
    J = \partial e / \partial q_a,\quad \lambda = \lambda_0 + |e|^2

(the damping of Sugihara, IEEE T-RO 2011: large far from a solution, vanishing at it), each
step capped at ``max_step`` rad (or m) and projected (:math:`\Pi`) onto the joint limits, so
every iterate and every solution respects them. Orientation residual ``e_R``: ``"full"``
:math:`\mathrm{vec}(R - R_d)/\sqrt 2` (its norm is :math:`2 \sin(\alpha/2)` for the angle
alpha between R and R_d: zero only at R = R_d; the cross-product residual
:math:`\tfrac12 \sum_i R_{:,i} \times R_{d,:,i}` also vanishes half a turn off, and the
iteration was drawn there); ``"axis"`` :math:`R a - a_d`, only the direction of the frame's
axis ``a`` (the roll about it is free); ``"none"``: position only.

Targets are world-frame; each is moved into the platform frame (the platform at the origin)
in NumPy, so the compiled residual depends on the arm joints alone. All targets and seeds
are solved at once: the residual and its Jacobian are one CasADi function mapped over the
batch, the damped normal equations one batched ``numpy.linalg.solve``. Several seeds per
target (the given ones, then seeded-random ones inside the limits); among the seeds that
converge the solution with the highest ``score`` is kept (default: the first converged seed).
Everything derives from the robot's own symbolic kinematics: no closed form, no Pinocchio.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import casadi as ca
import numpy as np

from mmplan.arrays import Array, BoolArray
from mmplan.compile import codegen as cg
from mmplan.compile.fingerprint import robot_fingerprint, source_fingerprint
from mmplan.errors import InputError
from mmplan.robot import dynamics
from mmplan.robot.robot import Robot

Orientation = Literal["full", "axis", "none"]


@dataclass(frozen=True)
class IkResult:
    """Solutions of a batch of IK problems.

    Attributes:
        q: Arm joints (N, n_arm) (the best seed of each target; the last iterate when none
            converged).
        ok: Converged within the tolerances (N,).
        position_error: |p_d - p(q)| [m] (N,).
        orientation_error: |e_R(q)| (N,) (0 for ``"none"``).
    """

    q: Array
    ok: BoolArray
    position_error: Array
    orientation_error: Array


def planar_inverse(base: Array, position: Array, rotation: Array) -> tuple[Array, Array]:
    """World targets (N, 3), (N, 3, 3) in the frames of platforms at ``base`` (N, 3) =
    (x, y, theta): p_local = Rz(theta)^T (p - (x, y, 0)), R_local = Rz(theta)^T R."""
    c, s = np.cos(base[:, 2]), np.sin(base[:, 2])
    Rt = np.zeros((len(base), 3, 3))
    Rt[:, 0, 0], Rt[:, 0, 1], Rt[:, 1, 0], Rt[:, 1, 1] = c, s, -s, c
    Rt[:, 2, 2] = 1.0
    d = position - np.column_stack([base[:, :2], np.zeros(len(base))])
    return np.einsum("nij,nj->ni", Rt, d), np.einsum("nij,njk->nik", Rt, rotation)


class ArmIK:
    """Batched numeric IK of ``robot``'s arm (module docstring).

    Args:
        robot: Any robot; its arm coordinates (``robot.arm_indices``) are solved for, the
            platform coordinates are the given base pose (wheel angles do not move the arm).
        orientation: ``"full"``, ``"axis"`` or ``"none"`` (module docstring).
        axis: The end-effector frame's axis whose direction ``"axis"`` controls.
        compiled: Compile the residual and the pose to C (cached by the robot model, orientation
            and axis: a later process builds no symbolic model; about 5x faster on TIAGo);
            the CasADi virtual machine without a compiler (a notice).

    Raises:
        InputError: a platform without a planar pose (x, y, theta first), or a zero axis.
    """

    def __init__(
        self,
        robot: Robot,
        orientation: Orientation = "full",
        axis: tuple[float, float, float] = (0.0, 0.0, 1.0),
        compiled: bool = True,
    ) -> None:
        if tuple(robot.platform_coordinates[:3]) != ("x", "y", "theta"):
            raise InputError(
                "robot", f"numeric IK needs a planar platform pose (x, y, theta), "
                f"{robot.name} has {robot.platform_coordinates}"
            )
        a = np.asarray(axis, dtype=float)
        if not np.isfinite(a).all() or np.linalg.norm(a) < 1e-12:
            raise InputError("axis", f"must be a non-zero vector, got {axis}")
        self.robot = robot
        self.orientation = orientation
        self.axis = a / np.linalg.norm(a)
        self.n_arm = len(robot.arm_indices)
        lo = np.asarray(robot.limits.joint_min, dtype=float)
        hi = np.asarray(robot.limits.joint_max, dtype=float)
        self.lower, self.upper = lo, hi
        self._maps: dict[int, ca.Function] = {}  # the residual mapped over batches, by size
        self.backend = "vm"
        library = self._library() if compiled else None
        try:
            if library is not None:  # loaded without building the symbolic model
                self._residual, self._pose = cg.load(["ik_residual", "ik_pose"], library)
                self.backend = "c"
        except RuntimeError:  # unreadable (another machine's, damaged): the VM, said once
            cg.notice(f"{library} could not be loaded: the arm IK runs on CasADi's virtual "
                      "machine")  # fmt: skip
        if self.backend == "vm":
            self._residual, self._pose = self._build()
        self.n_residual = int(self._residual.size1_out(0)) - 1

    def _library(self) -> str | None:
        """The compiled residual and pose (cached, keyed by the robot model, the orientation
        mode, the axis and the code: a later process builds no symbolic model); None without
        a compiler (a notice) or when the build fails."""
        if cg.compiler() is None:
            cg.notice(f"{cg.no_compiler()}: the arm IK runs on CasADi's virtual machine")
            return None
        parts = [
            robot_fingerprint(self.robot),
            repr((self.orientation, tuple(float(v) for v in self.axis))),
            source_fingerprint([__file__, dynamics.__file__, cg.__file__]),
        ]
        key = hashlib.sha256("\n".join(parts).encode()).hexdigest()[:24]
        return cg.compile_library(lambda: list(self._build()), "ik", ("-O1",), key=key)

    def _build(self) -> tuple[ca.Function, ca.Function]:
        """The residual and pose functions from the robot's symbolic model."""
        robot, orientation = self.robot, self.orientation
        s = robot.symbols
        qa = ca.SX.sym("qa", self.n_arm)
        full = ca.vertcat(ca.SX.zeros(robot.n_platform), qa)
        pose = ca.Function("pose", [s.q], [s.ee_position, s.ee_rotation])
        p, R = pose(full)
        pd, Rd = ca.SX.sym("p_d", 3), ca.SX.sym("R_d", 3, 3)
        # cos of the angle between R and R_d (between the axes for "axis"), kept as a guard:
        # the residuals vanish only at R = R_d (R a = a_d), never half a turn off.
        if orientation == "full":
            e_r = ca.vec(R - Rd) / np.sqrt(2.0)
            cos = (ca.trace(Rd.T @ R) - 1) / 2
        elif orientation == "axis":
            ax = ca.DM(self.axis)
            e_r = R @ ax - Rd @ ax
            cos = ca.dot(R @ ax, Rd @ ax)
        else:
            e_r, cos = ca.SX(0, 1), ca.SX(1)
        e = ca.vertcat(pd - p, e_r, cos)
        residual = ca.Function("ik_residual", [qa, pd, ca.vec(Rd)], [e, ca.jacobian(e[:-1], qa)])
        J6 = ca.vertcat(ca.jacobian(p, qa), dynamics.angular_jacobian(R, qa))
        w = ca.sqrt(ca.fmax(ca.det(J6 @ J6.T), 0)) if self.n_arm >= 6 else ca.SX(0)
        return residual, ca.Function("ik_pose", [qa], [p, ca.vec(R), w])

    def forward(self, q_arm: Array) -> tuple[Array, Array]:
        """Position (N, 3) and rotation (N, 3, 3) of the end effector in the platform frame."""
        q = np.atleast_2d(np.asarray(q_arm, dtype=float))
        p, R, _ = self._pose.map(len(q))(q.T)
        rot = np.asarray(R, dtype=float).T.reshape(len(q), 3, 3).transpose(0, 2, 1)
        return np.asarray(p, dtype=float).T, rot

    def manipulability(self, q_arm: Array) -> Array:
        """Yoshikawa's w = sqrt(det(J J^T)) of the 6-row tool Jacobian (linear and angular
        velocity per arm joint rate) at each row of ``q_arm`` (N,) ([Nagatani] eq. (1));
        0 for arms of fewer than 6 joints."""
        q = np.atleast_2d(np.asarray(q_arm, dtype=float))
        return np.asarray(self._pose.map(len(q))(q.T)[2], dtype=float).ravel()

    def reach(self) -> float:
        """An upper bound of the horizontal distance from the platform frame's origin to the
        end-effector point over every arm configuration [m]: the horizontal distance of the
        first arm joint (fixed on the platform), plus the lengths of the rigid links from it
        to the end-effector body (joint origins; a revolute joint moves no origin), the stroke
        of prismatic joints and the end-effector offset."""
        robot, tree = self.robot, self.robot.tree
        lo, hi = robot.limits.joint_min, robot.limits.joint_max
        arm = {robot.coordinates[i]: k for k, i in enumerate(robot.arm_indices)}
        chain = []
        body = robot.end_effector.body
        while body != "platform":
            joint = tree.parent_joint(body)
            if joint.parent == "world" or joint.coordinate in robot.platform_coordinates:
                break
            chain.append(joint)
            body = joint.parent
        moving = [j for j in chain if j.coordinate in arm]
        if not moving:
            return float(np.linalg.norm(robot.ee_position(np.zeros(robot.n))[:2]))
        first = moving[-1]  # nearest the platform
        total = float(np.linalg.norm(robot.body_positions(np.zeros(robot.n))[first.child][:2]))
        total += float(np.linalg.norm(robot.end_effector.offset))
        for joint in chain[: chain.index(first) + 1]:
            if joint is not first:
                total += float(np.linalg.norm(joint.origin_xyz))
            if joint.coordinate in arm and joint.kind.name == "PRISMATIC":
                k = arm[joint.coordinate]
                total += float(max(abs(lo[k]), abs(hi[k])))
        return total

    def random_seeds(self, count: int, seed: int = 0) -> Array:
        """``count`` arm configurations uniform inside the limits (+-pi where unbounded)."""
        lo = np.where(np.isfinite(self.lower), self.lower, -np.pi)
        hi = np.where(np.isfinite(self.upper), self.upper, np.pi)
        return np.random.default_rng(seed).uniform(lo, hi, size=(count, self.n_arm))

    def _evaluate(self, q: Array, p: Array, R: Array) -> tuple[Array, Array]:
        """Residuals with the alignment cosine last (B, m + 1) and Jacobians of the residuals
        (B, m, n_arm) of a batch."""
        B, m = len(q), self.n_residual
        if B not in self._maps:
            self._maps[B] = self._residual.map(B)
        e, J = self._maps[B](q.T, p.T, R.transpose(0, 2, 1).reshape(B, 9).T)
        E = np.asarray(e, dtype=float).T.reshape(B, m + 1)
        Jm = np.asarray(J, dtype=float).reshape(m, B, self.n_arm).transpose(1, 0, 2)
        return E, Jm

    def solve(
        self,
        base: Array,
        position: Array,
        rotation: Array | None = None,
        seeds: Array | None = None,
        random_seeds: int = 4,
        score: Callable[[Array], Array] | None = None,
        iterations: int = 100,
        tolerance: float = 1e-6,
        damping: float = 1e-4,
        max_step: float = 0.5,
        rng_seed: int = 0,
        patience: int = 10,
    ) -> IkResult:
        """Solve N targets at once (module docstring).

        Args:
            base: Platform poses (x, y, theta) (N, 3) or (3,).
            position: Target positions in the world (N, 3) or (3,) [m].
            rotation: Target rotations in the world (N, 3, 3) or (3, 3) (ignored for
                ``"none"``; identity when None).
            seeds: Initial arm joints, shared (S, n_arm) or per target (N, S, n_arm); tried
                first.
            random_seeds: Further seeds uniform inside the limits (the same for every target).
            score: q (M, n_arm) -> (M,), higher is better, to choose among converged seeds.
            iterations: Iterations at most.
            tolerance: Converged when both the position error [m] and the orientation
                residual are below this.
            damping: lambda_0.
            max_step: Largest joint change per iteration (infinity norm) [rad or m].
            rng_seed: Seed of the random seeds.
            patience: Give a seed up after this many iterations without its residual norm
                falling by 0.1 % (a local minimum, or a target out of reach).
        """
        pos = np.atleast_2d(np.asarray(position, dtype=float))
        N = max(len(pos), len(np.atleast_2d(base)))
        pos = np.broadcast_to(pos, (N, 3))
        b = np.broadcast_to(np.atleast_2d(np.asarray(base, dtype=float)), (N, 3))
        rot = np.eye(3) if rotation is None else np.asarray(rotation, dtype=float)
        rot = np.broadcast_to(rot, (N, 3, 3))
        p_loc, R_loc = planar_inverse(np.asarray(b), np.asarray(pos), np.asarray(rot))
        given = np.zeros((N, 0, self.n_arm))
        if seeds is not None:
            sd = np.asarray(seeds, dtype=float)
            given = np.broadcast_to(sd if sd.ndim == 3 else sd[None], (N, *sd.shape[-2:]))
        extra = self.random_seeds(random_seeds, rng_seed)
        start = np.concatenate([given, np.broadcast_to(extra[None], (N, *extra.shape))], axis=1)
        S = start.shape[1]
        if S == 0:
            raise InputError("seeds", "no seeds: give seeds or random_seeds >= 1")
        lo = np.where(np.isfinite(self.lower), self.lower, -np.inf)
        hi = np.where(np.isfinite(self.upper), self.upper, np.inf)
        q = np.clip(start.reshape(N * S, self.n_arm), lo, hi)
        P, R = np.repeat(p_loc, S, axis=0), np.repeat(R_loc, S, axis=0)
        active = np.ones(N * S, dtype=bool)
        best = np.full(N * S, np.inf)  # smallest |e| so far
        stalled = np.zeros(N * S, dtype=int)  # iterations since |e| last fell by 0.1 %
        eye = np.eye(self.n_arm)
        E = np.zeros((N * S, self.n_residual + 1))
        for _ in range(iterations):
            idx = np.flatnonzero(active)
            if not idx.size:
                break
            E_a, J_a = self._evaluate(q[idx], P[idx], R[idx])
            E[idx] = E_a
            done = self._converged(E_a, tolerance)
            norm = np.linalg.norm(E_a[:, :-1], axis=1)
            better = norm < 0.999 * best[idx]
            best[idx] = np.minimum(best[idx], norm)
            stalled[idx] = np.where(better, 0, stalled[idx] + 1)
            active[idx[done]] = False
            active[idx[stalled[idx] >= patience]] = False  # a local minimum or out of reach
            keep = ~done & (stalled[idx] < patience)
            idx, E_a, J_a = idx[keep], E_a[keep], J_a[keep]
            if not idx.size:
                break
            E_a = E_a[:, :-1]
            lam = damping + np.einsum("bi,bi->b", E_a, E_a)
            JtJ = np.einsum("bij,bik->bjk", J_a, J_a) + lam[:, None, None] * eye
            step = -np.linalg.solve(JtJ, np.einsum("bij,bi->bj", J_a, E_a)[..., None])[..., 0]
            big = np.abs(step).max(axis=1, keepdims=True)
            step *= np.minimum(1.0, max_step / np.maximum(big, 1e-300))
            q[idx] = np.clip(q[idx] + step, lo, hi)
        if active.any():
            idx = np.flatnonzero(active)
            E[idx] = self._evaluate(q[idx], P[idx], R[idx])[0]
        ok = self._converged(E, tolerance).reshape(N, S)
        pos_err = np.linalg.norm(E[:, :3], axis=1).reshape(N, S)
        ori_err = np.linalg.norm(E[:, 3:-1], axis=1).reshape(N, S)
        Q = q.reshape(N, S, self.n_arm)
        rank = np.where(ok, 0.0, -np.inf) - 1e-12 * np.arange(S)[None]  # first converged
        if score is not None and ok.any():
            values = np.full(N * S, -np.inf)
            flat = np.flatnonzero(ok.ravel())
            values[flat] = score(q[flat])
            rank = np.where(ok, values.reshape(N, S), -np.inf)
        rank = np.where(ok.any(axis=1, keepdims=True), rank, -(pos_err + ori_err))
        pick = np.argmax(rank, axis=1)
        rows = np.arange(N)
        return IkResult(Q[rows, pick], ok[rows, pick], pos_err[rows, pick], ori_err[rows, pick])

    @staticmethod
    def _converged(E: Array, tolerance: float) -> BoolArray:
        """Rows of [e; cos] (B, m + 1) within the tolerance and not half a turn off."""
        pos = np.linalg.norm(E[:, :3], axis=1) < tolerance
        ori = np.linalg.norm(E[:, 3:-1], axis=1) < tolerance if E.shape[1] > 4 else True
        return np.asarray(pos & ori & (E[:, -1] > 0.0))
