"""Console output of the ``mmplan`` command: the metric listings (progress: :mod:`.progress`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import mmplan

if TYPE_CHECKING:
    from rich.console import Console

    from mmplan.io.export import Exported
    from mmplan.robot import RateLimits
    from mmplan.verify.rates import RateReport


class _FirstUse:
    """A rich ``Console`` made when first used: importing rich costs ~50 ms of a start, and
    ``mmplan plan -q`` that succeeds prints nothing."""

    def __init__(self, stderr: bool) -> None:
        self._stderr = stderr
        self._console: Console | None = None

    def made(self) -> Console:
        """The console itself (made now if need be)."""
        if self._console is None:
            from rich.console import Console

            self._console = Console(stderr=self._stderr, highlight=False, soft_wrap=True)
        return self._console

    def __getattr__(self, name: str) -> Any:
        return getattr(self.made(), name)


out = cast("Console", _FirstUse(stderr=False))
err = cast("Console", _FirstUse(stderr=True))


def made(console: Console) -> Console:
    """``console`` itself: the rich Console behind :data:`out` or :data:`err` (made now if need
    be), for code that hands it to rich (a live display needs the Console, not a stand-in)."""
    stand_in: object = console
    return stand_in.made() if isinstance(stand_in, _FirstUse) else console


def _fmt(value: Any, unit: str = "", digits: int = 4) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.{digits}g}{unit}"
    return f"{value}{unit}"


def _when(value: float | None, timed: bool) -> str:
    """An instant: ``13.78 s``, or ``s = 0.5`` when t is a segment's parameter (not time)."""
    if value is None:
        return "never"
    return f"{value:.4g} s" if timed else f"s = {value:.4g}"


def _row(label: str, value: str, rule: str = "") -> None:
    """``label: value`` and, in a third column, the threshold it is checked against."""
    text = f"{label + ':':23s}{value}"
    out.print(f"{text:46s} {rule}".rstrip() if rule else text, markup=False)


def _floor_row(clearance: Any, where: str = "") -> None:
    """The floor clearance row and its rule (:mod:`mmplan.verify.floor`)."""
    from mmplan.verify.floor import FLOOR_TOL

    floor = where.rpartition(", ")[2] if where else ""  # "floor z = h m"
    rule = (f"must be >= {FLOOR_TOL:g} m" + (f" ({floor}; arm spheres)" if floor else "")
            if clearance is not None else "no floor (ground: null) or no arm spheres")
    _row("min floor clearance", _fmt(clearance, " m"), rule)


def print_plan(result: mmplan.PlanResult, summary: dict[str, Any], written: Path) -> None:
    """Status, then the checker's numbers as written to summary.json: the reach time (from
    then on within the tolerance) apart from the trajectory's end (its last sample)."""
    reached = result.reached
    message = f" ({result.message})" if result.message and not reached else ""
    out.print(f"status: {result.status.value}{message}", markup=False)
    peaks = summary.get("peak_velocity")
    timed = not (isinstance(peaks, dict) and not peaks)  # no peaks: t is a segment parameter
    t_end = float(result.trajectory.t[-1]) if len(result.trajectory.t) else None
    final = summary.get("final_error_m")
    _row("reach time", _when(summary.get("duration_s"), timed),
         "within the goal tolerance from then on" if reached else "task not completed")
    _row("trajectory end", _when(t_end, timed), f"final error {_fmt(final, ' m')}")
    _row("T(1 cm)", _when(summary.get("duration_1cm_s"), timed))
    _row("T(1 mm)", _when(summary.get("duration_1mm_s"), timed))
    clearance = summary.get("min_clearance_m")
    _row("min clearance", _fmt(clearance, " m"),
         "must be >= 0 m" if clearance is not None else "no obstacles")
    _floor_row(summary.get("min_floor_clearance_m"))
    _row("compute time", _fmt(summary.get("compute_time_s"), " s", 3))
    out.print(f"written to {written}", markup=False)


def print_check(report: mmplan.CheckReport, trajectory_end_s: float | None = None) -> None:
    """Every quantity the checker computes with the threshold it must meet ("info": reported,
    not a pass criterion); then the rate limits with theirs.

    Args:
        report: The checker's report.
        trajectory_end_s: The trajectory's last sample time, shown apart from the reach time
            when given (the report does not hold it).
    """
    from mmplan.verify.check import DQ_REL_TOL, EE_TOL, LIMIT_TOL, PFAFFIAN_TOL, TORQUE_TOL
    from mmplan.verify.consistency import (
        DDQ_ABS_TOL,
        DDQ_LOCAL_TOL,
        DDQ_REL_TOL,
        START_TOL,
        TAU_MODEL_TOL,
    )

    rates = getattr(report, "rates", None)
    timed = bool(getattr(rates, "timed", True))
    cons = report.consistency
    completed = "completed" if report.task_completed else "not completed"
    _row("status (claimed)", _fmt(report.status),
         f"must be a status name and must agree: the task is {completed}")
    start = ("-" if cons.start_deviation is None
             else f"{cons.start_deviation:.3g} ({cons.start_where})" if cons.start_deviation
             else "0")
    _row("start vs scenario", f"{start}, t0 = {_when(cons.start_time, timed)}",
         f"must be <= {START_TOL:g} (rad or m), t0 = 0" if cons.start_deviation is not None
         else f"segment task: the planner chooses its start; t0 must be 0 (+-{START_TOL:g})")
    required = ", ".join(cons.required) or "none"
    _row("effort columns", "MISSING or misnamed" if cons.columns else "complete",
         f"required: {required} (tau.* with torque limits or by the method)")
    _row("samples", str(report.samples), "values must be finite: "
         + ("yes" if report.finite else "NO"))
    _row("reach time T(tol)", _when(report.duration_s, timed),
         f"error <= {report.tolerance:g} m from then on (scenario tolerance)")
    if trajectory_end_s is not None:
        _row("trajectory end", _when(trajectory_end_s, timed), "info")
    _row("T(1 cm)", _when(report.duration_1cm_s, timed), "info")
    _row("T(1 mm)", _when(report.duration_1mm_s, timed), "info")
    _row("final error", _fmt(report.final_error_m, " m"), "info")
    _row("min clearance", _fmt(report.min_clearance_m, " m"),
         "must be >= 0 m" if report.min_clearance_m is not None else "no obstacles")
    _floor_row(report.min_floor_clearance_m, report.floor_where)
    self_where = f" ({report.self_clearance_where})" if report.self_clearance_where else ""
    _row("min self-clearance", _fmt(report.min_self_clearance_m, " m") + self_where,
         "must be >= 0 m (self-collision pairs)" if report.min_self_clearance_m is not None
         else "no self-collision pairs")
    _row("joint limit violation", _fmt(report.max_joint_limit_violation),
         f"must be <= {LIMIT_TOL:g} (rad or m)")
    source = f", {report.torque_source} efforts" if report.torque_source else ""
    _row("torque violation", _fmt(report.max_torque_violation),
         f"must be <= {TORQUE_TOL:g} (N m or N{source})")
    _row("tau vs model", _fmt(cons.tau_model_deviation),
         f"must be <= {TAU_MODEL_TOL:g} (N m or N)" if cons.tau_model_deviation is not None
         else "no tau columns")
    _row("pfaffian residual", _fmt(report.max_pfaffian_residual, " m/s"),
         f"must be <= {PFAFFIAN_TOL:g} m/s")
    dq_limit = DQ_REL_TOL * max(report.dq_scale, 1e-3)
    _row("dq residual", _fmt(report.dq_residual, " /s"),
         f"must be <= {dq_limit:.3g} /s ({DQ_REL_TOL:g} x max |dq| {report.dq_scale:.3g})")
    _row("ddq vs interpolant", _fmt(cons.ddq_excess),
         f"must be <= {cons.ddq_allowed:.3g} there ({DDQ_LOCAL_TOL:g} x the local spread + "
         f"{DDQ_REL_TOL:g} x the coordinate's peak |ddq| + {DDQ_ABS_TOL:g}; outside the "
         f"adjacent steps' range)"
         if math.isfinite(cons.ddq_allowed)
         else "one sample: nothing to compare")
    _row("ee vs FK", _fmt(report.ee_deviation_m, " m"), f"must be <= {EE_TOL:g} m")
    _row("manipulability", f"start {_fmt(report.manipulability_start)}, end "
         f"{_fmt(report.manipulability_end)}, min {_fmt(report.manipulability_min)}", "info")
    if rates is not None:
        print_rates(rates)


def print_rates(rates: RateReport) -> None:
    """Each rate limit with its thresholds: the dq/ddq columns' peak, the steps' least need."""
    from mmplan.verify.rates import DQ_TOL, RATE_REL_TOL

    if not rates.timed:
        out.print(f"{'rate limits:':23s}t is the segment parameter, not time: not checkable"
                  + (f" ({', '.join(rates.untimed_limits)} set)" if rates.untimed_limits else ""),
                  markup=False)
        return
    out.print(f"{'platform peaks:':23s}speed {_fmt(rates.peak_platform_speed_mps, ' m/s')}, "
              f"yaw rate {_fmt(rates.peak_platform_yaw_rate_radps, ' rad/s')}, acceleration "
              f"{_fmt(rates.peak_platform_acceleration_mps2, ' m/s^2')}", markup=False)
    if not rates.checks:
        out.print(f"{'rate limits:':23s}none set", markup=False)
        return
    out.print(f"{'rate limits:':23s}peak of the dq/ddq columns and least need of any motion "
              f"between samples (from q, dq; dq +-{DQ_TOL:g}) <= limit (1 + {RATE_REL_TOL:g})",
              markup=False)
    for c in rates.checks:
        verdict = "ok" if not c.failures() else "FAIL"
        margin = c.limit - c.peak
        if abs(margin) <= 1e-9 * max(abs(c.limit), 1.0):
            margin = 0.0  # at the limit to rounding ("margin -3.2e-14: ok" puzzled a new user)
        out.print(f"  {c.label + ':':28s}peak {c.peak:.4g}, between samples "
                  f"{c.step_peak:.4g}, limit {c.limit:.4g} {c.unit}, margin "
                  f"{margin:.3g}: {verdict}",
                  markup=False)


def rate_limits_text(rates: RateLimits) -> tuple[str, str]:
    """(velocity, acceleration) limits in brief, coordinates with equal bounds grouped."""
    def brief(bounds: Mapping[str, float], linear: float, angular: float, per: str) -> str:
        parts = []
        if math.isfinite(linear):
            parts.append(f"platform {linear:.4g} m{per}")
        if math.isfinite(angular):
            parts.append(f"yaw {angular:.4g} rad{per}")
        groups: dict[float, list[str]] = {}
        for name, value in bounds.items():
            if math.isfinite(value):
                groups.setdefault(value, []).append(name)
        parts += [f"{' '.join(names)} {value:.4g}" for value, names in groups.items()]
        return ", ".join(parts) or "off"

    return (brief(rates.velocity, rates.platform_speed, rates.platform_yaw_rate, "/s"),
            brief(rates.acceleration, rates.platform_acceleration,
                  rates.platform_yaw_acceleration, "/s^2"))


def unavailable_text(exc: mmplan.InputError) -> tuple[str, str]:
    """``mmplan robots``: why a built-in robot cannot be built here, as ("not installed", the
    command that installs its files) or ("not available", the problem)."""
    from mmplan.extras import install_command

    hint = install_command("robots")
    if hint in exc.problem:
        return "not installed", hint
    return "not available", exc.problem


def print_export(done: Exported) -> None:
    """What ``mmplan export`` wrote: samples, residuals, the plan folder and the bag topics."""
    r = done.resampled
    out.print(f"resampled {r.source_samples} -> {r.trajectory.samples} samples at "
              f"{r.rate_hz:g} Hz; Pfaffian residual {r.pfaffian_interpolated:.2g} m/s after "
              f"interpolation, {r.pfaffian:.2g} m/s after projecting dq "
              f"(dq changed by {r.dq_projection:.2g})", markup=False)
    if done.plan_dir is not None:
        verdict = "check passed" if not done.failures else f"{len(done.failures)} checks failed"
        out.print(f"plan folder: {done.plan_dir} ({verdict})", markup=False)
    if done.bag is not None:
        b = done.bag
        topics = ", ".join(f"{topic} {count}" for topic, count in b.counts.items())
        out.print(f"ROS 2 bag: {b.path} (messages: {topics}; {b.points} trajectory points"
                  f"{', with efforts' if b.effort else ''})", markup=False)
