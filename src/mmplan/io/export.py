r"""A plan at a fixed control rate: resampling and the ``mmplan export`` entry point.

Planners write samples at uneven times (0.02-0.107 s after the extended-Jacobian time
scaling); a robot's controller runs at a fixed rate. :func:`resample` evaluates one
interpolant of the plan at :math:`t_0 + k/f` (rate :math:`f` in Hz), so that the exported
q, dq, ddq are exact derivatives of one curve, not held samples:

* **q, dq, ddq**: a piecewise quartic Hermite polynomial. On each original step
  :math:`[t_i, t_{i+1}]` (length :math:`h`, :math:`s = (t - t_i)/h`) it matches
  :math:`q_i, \dot q_i, \ddot q_i` at :math:`t_i` and :math:`q_{i+1}, \dot q_{i+1}` at
  :math:`t_{i+1}`:

  .. math::

      q(s) = \sum_{k=0}^{4} c_k s^k,\quad c_0 = q_i,\ c_1 = h\dot q_i,\
      c_2 = \tfrac{h^2}{2}\ddot q_i,\ c_3 = 4P - V,\ c_4 = V - 3P,

  with :math:`P = q_{i+1} - c_0 - c_1 - c_2` and :math:`V = h\dot q_{i+1} - c_1 - 2c_2`.
  The curve is C1 everywhere; its acceleration may jump at an original sample, as the
  planners' own does: a written ``ddq`` row is the acceleration on the step that starts
  there (the time scaling's rate :math:`\dot x` is constant per step). A C2 quintic through
  those one-sided values has to bulge between the samples: on youbot3r-obstacles-torque at
  100 Hz its peak acceleration is 49 rad/s^2 (the plan's: 37) and the model efforts exceed
  the 1.5 N m wheel limit by 0.58 N m; the quartic: 41 rad/s^2, 0.047 N m.
* **Pfaffian constraint**: the interpolant satisfies :math:`A(q)\dot q = 0` only at the
  original samples (in between, about 1e-5 m/s on that plan, above the checker's 1e-6).
  :math:`\dot q` is therefore projected onto :math:`\ker A(q)`:
  :math:`\dot q \leftarrow \dot q - A^T (A A^T)^{-1} A \dot q`, which changes it by no more
  than that residual (``Resampled.dq_projection``); q and ddq are kept.
* **tau, u and extra columns** (where present): linear interpolation (efforts stay within
  any box limits the samples respect; they are not recomputed from the model).
* **ee**: recomputed from q by the robot's forward kinematics.

The last step is shorter when the duration is not a multiple of :math:`1/f`: the export
ends exactly at the plan's final time (steps :math:`1/f`, the last one between
:math:`10^{-3}/f` and :math:`1.001/f`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from mmplan.arrays import Array
from mmplan.errors import InputError
from mmplan.robot import Robot
from mmplan.trajectory import Trajectory

if TYPE_CHECKING:
    from mmplan.io.ros2 import BagSummary

#: Control rates accepted [Hz]: a robot controller runs at 1 Hz to a few kHz.
MIN_RATE_HZ = 1.0
MAX_RATE_HZ = 10_000.0
#: Samples a resampled plan may hold (10 kHz over 200 s).
MAX_SAMPLES = 2_000_000
DEFAULT_RATE_HZ = 100.0


def check_rate(rate: float, duration: float | None = None) -> float:
    """``rate`` as float when it is a usable control rate [Hz], else InputError (``--rate``)."""
    try:
        value = float(rate)
    except (TypeError, ValueError):
        raise InputError("--rate", f"{rate!r} is not a number (Hz)") from None
    if not math.isfinite(value) or not MIN_RATE_HZ <= value <= MAX_RATE_HZ:
        raise InputError("--rate", f"{rate!r} Hz is outside [{MIN_RATE_HZ:g}, {MAX_RATE_HZ:g}] Hz")
    if duration is not None and duration * value + 2 > MAX_SAMPLES:
        raise InputError("--rate", f"{value:g} Hz over {duration:.4g} s gives "
                         f"{int(duration * value) + 2} samples; at most {MAX_SAMPLES}")
    return value


def control_times(t0: float, t1: float, rate: float) -> Array:
    """Sample times t0 + k/rate before t1 (by more than 1e-3/rate), then t1 exactly, (M,)."""
    if t1 <= t0:
        return np.array([t0], dtype=float)
    count = math.ceil((t1 - t0) * rate - 1e-3)
    return np.append(t0 + np.arange(count) / rate, t1)


def hermite_quartic(t: Array, q: Array, dq: Array, ddq: Array,
                    times: Array) -> tuple[Array, Array, Array]:
    """The piecewise quartic of the module doc and its derivatives at ``times`` (inside t).

    Args:
        t: Sample times (N,), strictly increasing, N >= 2.
        q, dq, ddq: Samples (N, n).
        times: Where to evaluate (M,), within [t[0], t[-1]].

    Returns:
        q, dq, ddq at ``times``, each (M, n).
    """
    i = np.clip(np.searchsorted(t, times, side="right") - 1, 0, len(t) - 2)
    h = (t[i + 1] - t[i])[:, None]
    s = ((times - t[i]) / (t[i + 1] - t[i]))[:, None]
    c0, c1, c2 = q[i], h * dq[i], 0.5 * h * h * ddq[i]
    P = q[i + 1] - c0 - c1 - c2
    V = h * dq[i + 1] - c1 - 2.0 * c2
    c3, c4 = 4.0 * P - V, V - 3.0 * P
    pos = c0 + s * (c1 + s * (c2 + s * (c3 + s * c4)))
    vel = (c1 + s * (2.0 * c2 + s * (3.0 * c3 + s * 4.0 * c4))) / h
    acc = (2.0 * c2 + s * (6.0 * c3 + s * 12.0 * c4)) / (h * h)
    return pos, vel, acc


def _pfaffian_rows(robot: Robot, q: Array) -> Array:
    """A(q_k) for every sample, (M, h, n)."""
    M = q.shape[0]
    A = np.asarray(robot.functions["pfaffian"].map(M)(np.ascontiguousarray(q.T)), dtype=float)
    return np.ascontiguousarray(A.reshape(robot.h, M, robot.n).transpose(1, 0, 2))


def pfaffian_residuals(robot: Robot, q: Array, dq: Array) -> Array:
    """|A(q_k) dq_k|_2 per sample [m/s], (M,) (zeros for a robot without constraints)."""
    if robot.h == 0:
        return np.zeros(q.shape[0])
    return np.asarray(np.linalg.norm(np.einsum("khn,kn->kh", _pfaffian_rows(robot, q), dq),
                                     axis=1), dtype=float)


def project_to_constraints(robot: Robot, q: Array, dq: Array) -> Array:
    """dq - A^T (A A^T)^-1 A dq per sample: the nearest velocities with A(q) dq = 0, (M, n)."""
    if robot.h == 0:
        return dq.copy()
    A = _pfaffian_rows(robot, q)  # (M, h, n)
    r = np.einsum("khn,kn->kh", A, dq)
    lam = np.linalg.solve(A @ A.transpose(0, 2, 1), r[:, :, None])[:, :, 0]  # (M, h)
    return np.asarray(dq - np.einsum("khn,kh->kn", A, lam), dtype=float)


@dataclass(frozen=True)
class Resampled:
    """A trajectory at a fixed control rate, and what the interpolation left.

    Attributes:
        trajectory: The resampled trajectory.
        rate_hz: The control rate [Hz].
        source_samples: Samples of the original trajectory.
        pfaffian_interpolated: max_t |A(q) dq| of the interpolant before the projection [m/s].
        dq_projection: max_t |dq change| made by the projection (inf-norm; m/s or rad/s).
        pfaffian: max_t |A(q) dq| after the projection [m/s].
    """

    trajectory: Trajectory
    rate_hz: float
    source_samples: int
    pfaffian_interpolated: float
    dq_projection: float
    pfaffian: float

    def info(self) -> dict[str, Any]:
        """These numbers as a JSON-ready dict (summary.json ``planner_info.export``)."""
        return {"rate_hz": self.rate_hz, "source_samples": self.source_samples,
                "samples": self.trajectory.samples,
                "interpolation": "quartic Hermite (q, dq, ddq); tau, u, extra linear",
                "pfaffian_residual_interpolated": self.pfaffian_interpolated,
                "dq_projection_max": self.dq_projection}


def resample_detailed(trajectory: Trajectory, rate: float, robot: Robot) -> Resampled:
    """:func:`resample` with the residuals it measured (see :class:`Resampled`).

    Raises:
        InputError: a bad rate, coordinates that are not the robot's, or non-finite values.
    """
    tr = trajectory
    if tr.coordinates != robot.coordinates:
        raise InputError("trajectory", f"coordinates {tr.coordinates} are not those of "
                         f"{robot.name} {robot.coordinates}")
    if not tr.is_finite():
        raise InputError("trajectory", "holds NaN or inf values; there is no motion to export")
    rate = check_rate(rate, tr.duration)
    times = control_times(float(tr.t[0]), float(tr.t[-1]), rate)
    if tr.samples == 1:
        q, dq, ddq = tr.q.copy(), tr.dq.copy(), tr.ddq.copy()
    else:
        q, dq, ddq = hermite_quartic(tr.t, tr.q, tr.dq, tr.ddq, times)
        q[-1], dq[-1], ddq[-1] = tr.q[-1], tr.dq[-1], tr.ddq[-1]  # exactly the plan's end
    before = pfaffian_residuals(robot, q, dq)
    projected = project_to_constraints(robot, q, dq)
    change = float(np.max(np.abs(projected - dq)))
    after = pfaffian_residuals(robot, q, projected)

    def linear(values: Array) -> Array:
        if tr.samples == 1:
            return values.copy()
        v2 = values.reshape(tr.samples, -1)
        out = np.column_stack([np.interp(times, tr.t, v2[:, j]) for j in range(v2.shape[1])])
        return out.reshape((len(times), *values.shape[1:]))

    ee = np.asarray(robot.functions["ee_position"].map(len(times))(np.ascontiguousarray(q.T)),
                    dtype=float).T
    out = Trajectory(coordinates=tr.coordinates, t=times, q=q, dq=projected, ddq=ddq, ee=ee,
                     actuators=tr.actuators, tau=None if tr.tau is None else linear(tr.tau),
                     u=None if tr.u is None else linear(tr.u),
                     extra={k: linear(np.asarray(v, dtype=float)) for k, v in tr.extra.items()})
    return Resampled(out, rate, tr.samples, float(np.max(before)), change, float(np.max(after)))


def resample(trajectory: Trajectory, rate: float, robot: Robot) -> Trajectory:
    """``trajectory`` sampled at ``rate`` Hz (see the module doc for the interpolation).

    Args:
        trajectory: A planned trajectory (t in seconds).
        rate: Control rate [Hz], in [MIN_RATE_HZ, MAX_RATE_HZ].
        robot: The robot it moves (forward kinematics, Pfaffian constraints).

    Raises:
        InputError: a bad rate, coordinates that are not the robot's, or non-finite values.
    """
    return resample_detailed(trajectory, rate, robot).trajectory


@dataclass(frozen=True)
class Exported:
    """What :func:`export_plan` wrote.

    Attributes:
        resampled: The resampled trajectory and its residuals.
        plan_dir: The plan folder written (None without ``out``).
        bag: The rosbag2 written (None without ``ros2``).
    """

    resampled: Resampled
    plan_dir: Path | None = None
    bag: BagSummary | None = None


def export_plan(plan_dir: str | Path, *, rate: float = DEFAULT_RATE_HZ,
                out: str | Path | None = None, ros2: str | Path | None = None,
                step: Callable[[str], None] | None = None) -> Exported:
    """Resample the plan in ``plan_dir`` at ``rate`` Hz; write a plan folder and/or a bag.

    Each output is written completely or not at all (a temporary folder renamed into
    place); all arguments are checked before anything is written.

    Args:
        plan_dir: A plan folder (``mmplan plan ... --out plan_dir``).
        rate: Control rate [Hz].
        out: Plan folder to write, like :func:`mmplan.io.write_plan` (a new, empty or
            earlier plan folder); its summary.json is recomputed by the checker, its status,
            message and planner numbers are the plan's, ``planner_info.export`` holds
            :meth:`Resampled.info`; history.csv and artifacts.npz are carried over.
        ros2: rosbag2 folder to write (:func:`mmplan.io.ros2.write_bag`).
        step: Called with a short description as each step starts (progress lines).

    Raises:
        InputError: nothing to write, an unreadable plan, a bad rate, a plan whose t is not
            time (manipulability-area), an output that may not be written, rosbags missing.
    """
    from mmplan.io import ros2 as ros2_io  # no rosbags import until a bag is written
    from mmplan.io.plan_folder import check_out_dir, read_plan, read_summary, write_plan
    from mmplan.task import DrawSegment
    from mmplan.trajectory import PlanResult, Status

    note = step or (lambda _: None)
    if out is None and ros2 is None:
        raise InputError("export", "nothing to write: give --out DIR and/or --ros2 BAG")
    check_rate(rate)
    folder = Path(plan_dir)
    outputs = [(flag, Path(p)) for flag, p in (("--out", out), ("--ros2", ros2)) if p is not None]
    _check_apart(folder, outputs)
    if out is not None:
        check_out_dir(out)
    if ros2 is not None:
        ros2_io.require_rosbags()
        ros2_io.check_bag_dir(ros2)
    note("reading the plan")
    trajectory, scenario = read_plan(folder)
    summary = read_summary(folder)
    problem = scenario.build()
    if isinstance(problem.task, DrawSegment):
        raise InputError(str(folder), "t of a manipulability-area plan is the segment parameter, "
                         "not time: it has no control rate")
    status = summary.get("status")
    if status not in {s.value for s in Status}:
        raise InputError(str(folder / "summary.json"), f"status {status!r} is not a status")
    note(f"resampling at {float(rate):g} Hz")
    resampled = resample_detailed(trajectory, rate, problem.robot)
    written = bag = None
    if out is not None:
        note("writing and checking the plan folder")
        info = summary.get("planner_info")
        result = PlanResult(
            Status(status), resampled.trajectory, scenario.method,
            message=str(summary.get("message") or ""),
            compute_time_s=float(summary.get("compute_time_s") or 0.0),
            info={**(info if isinstance(info, dict) else {}), "export": resampled.info()},
            history=_read_history(folder / "history.csv"),
            artifacts=_read_artifacts(folder / "artifacts.npz"))
        fmt = "npz" if (folder / "trajectory.npz").is_file() else "csv"
        written = write_plan(out, result, problem, scenario, fmt=fmt)
    if ros2 is not None:
        note("writing the ROS 2 bag")
        bag = ros2_io.write_bag(resampled.trajectory, problem.robot, ros2)
    return Exported(resampled, written, bag)


def _check_apart(plan: Path, outputs: list[tuple[str, Path]]) -> None:
    """Outputs must be neither the plan folder, nor inside it or inside each other."""
    try:
        src = plan.resolve()
        full = [(flag, path, path.resolve()) for flag, path in outputs]
    except (OSError, RuntimeError) as exc:
        raise InputError("export", str(exc)) from None
    for flag, path, res in full:
        if res == src or src in res.parents:
            raise InputError(flag, f"{path} is the plan folder being exported or inside it; "
                             "name another folder")
    if len(full) == 2:
        (_, a, ra), (_, b, rb) = full
        if ra == rb or ra in rb.parents or rb in ra.parents:
            raise InputError("--ros2", f"{b} and --out {a} overlap; name separate folders")


def _read_history(path: Path) -> dict[str, Array]:
    """history.csv of a plan folder as named columns ({} when absent)."""
    if not path.is_file():
        return {}
    try:
        with path.open(encoding="utf-8") as fh:
            names = fh.readline().strip().split(",")
            data = np.loadtxt(fh, delimiter=",", ndmin=2, dtype=float)
    except (OSError, ValueError) as exc:
        raise InputError(str(path), f"cannot read: {exc}") from None
    if data.size == 0:
        return {}
    if data.shape[1] != len(names):
        raise InputError(str(path), f"{len(names)} header names but {data.shape[1]} columns")
    return {name: data[:, j] for j, name in enumerate(names)}


def _read_artifacts(path: Path) -> dict[str, Array]:
    """artifacts.npz of a plan folder ({} when absent)."""
    if not path.is_file():
        return {}
    try:
        with np.load(path, allow_pickle=False) as npz:
            return {key: np.asarray(npz[key]) for key in npz.files}
    except (OSError, ValueError) as exc:
        raise InputError(str(path), f"cannot read: {exc}") from None
