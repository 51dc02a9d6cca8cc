"""Compare a plan's summary.json with the metrics the checker recomputes (``mmplan check``).

summary.json is written from the same checker (:func:`mmplan.verify.check.check`) on the same
trajectory, and trajectory.csv round-trips float64 exactly, so every contract key
(docs/conventions.md) must agree up to rounding: a disagreement means the summary (or the
trajectory) was edited or written by something else, and the plan fails its check naming the
key.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from mmplan.trajectory import Status
from mmplan.verify.check import CheckReport

#: Relative and absolute tolerance of a numeric key: |a - b| <= ABS_TOL + REL_TOL max(|a|, |b|).
REL_TOL = 1e-6
ABS_TOL = 1e-9

#: Numeric contract keys recomputed by the checker (None allowed where the checker gives None).
NUMERIC_KEYS = (
    "duration_s", "duration_1cm_s", "duration_1mm_s", "final_error_m", "min_clearance_m",
    "min_self_clearance_m", "min_floor_clearance_m",
    "max_joint_limit_violation", "max_torque_violation", "max_pfaffian_residual",
    "manipulability_start", "manipulability_end", "manipulability_min",
    "peak_platform_speed_mps", "peak_platform_yaw_rate_radps", "peak_platform_acceleration_mps2",
    "peak_platform_yaw_acceleration_radps2",
)
#: Contract keys holding a mapping name -> number (every entry recomputed, no entry missing).
MAPPING_KEYS = ("peak_velocity", "peak_acceleration", "limit_margins")
STATUSES = tuple(s.value for s in Status)


def _number(value: Any) -> float | str | None:
    """A JSON value as float (None for null); a string describing it when it is no number."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float):
        return f"not a number ({type(value).__name__} {value!r})"
    return float(value)


def _agree(a: float | None, b: float | None) -> bool:
    if a is None or b is None:
        return a is None and b is None
    if not (math.isfinite(a) and math.isfinite(b)):
        return False
    return abs(a - b) <= ABS_TOL + REL_TOL * max(abs(a), abs(b))


def _finite_or_none(value: float | None) -> float | None:
    """Non-finite recomputed values are written as null (summary.json holds no NaN/inf)."""
    return value if value is None or math.isfinite(value) else None


def _disagreement(key: str, claimed: Any, recomputed: float | None) -> list[str]:
    """[] when the claimed JSON value agrees with the recomputed one, else one line."""
    value = _number(claimed)
    expected = _finite_or_none(recomputed)
    if isinstance(value, str):
        return [f"summary {key}: {value}"]
    if _agree(value, expected):
        return []
    shown = "null" if value is None else f"{value:.6g}"
    again = "null" if expected is None else f"{expected:.6g}"
    return [f"summary {key}: {shown} but recomputed {again}"]


def summary_disagreements(claimed: Mapping[str, Any], report: CheckReport,
                          planner: str) -> list[str]:
    """One line per summary.json key that disagrees with the recomputed ``report``.

    Args:
        claimed: summary.json as read.
        report: The checker's report on the plan's trajectory and scenario.
        planner: The planner method named by the plan's scenario.yaml.
    """
    out: list[str] = []
    status = claimed.get("status")
    if status not in STATUSES:
        out.append(f"summary status: {status!r} is not one of {', '.join(STATUSES)}")
    for key, name in (("robot", report.robot), ("planner", planner)):
        if claimed.get(key) != name:
            out.append(f"summary {key}: {claimed.get(key)!r} but the plan's scenario says "
                       f"{name!r}")
    samples = claimed.get("samples")
    if isinstance(samples, bool) or samples != report.samples:
        out.append(f"summary samples: {samples!r} but trajectory.csv has {report.samples}")
    recomputed = report.summary(status="", planner=planner, compute_time_s=0.0)
    for key in NUMERIC_KEYS:
        if key not in claimed:
            out.append(f"summary {key}: missing")
            continue
        out += _disagreement(key, claimed[key], recomputed[key])
    for key in MAPPING_KEYS:
        value, expected = claimed.get(key), recomputed[key]
        if not isinstance(value, Mapping):
            out.append(f"summary {key}: " + ("missing" if key not in claimed else
                                             f"not a mapping ({type(value).__name__})"))
            continue
        if set(value) != set(expected):
            out.append(f"summary {key}: names {sorted(value)} but recomputed {sorted(expected)}")
            continue
        for name in expected:
            out += _disagreement(f"{key}.{name}", value[name], expected[name])
    passed = claimed.get("check_passed")
    if passed is True and not report.ok:
        out.append("summary check_passed: true but the recomputed checks fail")
    return out
