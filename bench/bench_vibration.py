"""[Pajak]'s vibration claim: tip vibration of a compliant arm for its two example plans.

Plans [Pajak]'s runs, ``youbot4r-reach-unlimited`` (plain generator, [Pajak] eq. (12)) and
``youbot4r-reach-smooth-unlimited`` (virtual control, eq. (17)), without the youBot's velocity
and acceleration limits (the paper has none; with them the plain plan is re-timed), and drives
a tip mass on a 3-D spring-damper attached to the planned end-effector point
(:mod:`mmplan.analysis.vibration`) with each plan, for tip modes of 10, 15 and 20 Hz and
damping ratios 0.02 and 0.05. Prints, per variant: RMS of the vibration (deflection)
acceleration over the whole motion and over its first second, its peak, the RMS and peak of
the absolute tip acceleration, the largest spectral amplitude in the 10-20 Hz band, and the
plain / smooth ratios.

Run: ``python bench/bench_vibration.py`` (about 10 s).
"""

from __future__ import annotations

import numpy as np

from mmplan.analysis.vibration import VibrationResult, vibration_study
from mmplan.planners.extended_jacobian.planner import ExtendedJacobian
from mmplan.scenario.loader import load_scenario

VARIANTS = ("youbot4r-reach-unlimited", "youbot4r-reach-smooth-unlimited")
MODES = ((10.0, 0.02), (10.0, 0.05), (15.0, 0.02), (15.0, 0.05), (20.0, 0.02), (20.0, 0.05))


def _band(result: VibrationResult) -> float:
    band = (result.freq >= 10.0) & (result.freq <= 20.0)
    return float(result.amplitude[band].max())


def main() -> None:
    """Plan both variants and print the vibration table."""
    plans = {}
    for name in VARIANTS:
        problem = load_scenario(name).build()
        result = ExtendedJacobian().plan(problem)
        tr = result.trajectory
        print(
            f"{name:31s} {result.status.value}, {tr.duration:.2f} s, {tr.samples} samples, "
            f"dt {tr.t[1] - tr.t[0]:.4f} s, compute {result.compute_time_s:.1f} s"
        )
        plans[name] = (tr, problem.robot)
    print(
        "\nvibration acceleration = tip deflection acceleration [m/s^2]; tip = absolute tip "
        "acceleration;\nband = max one-sided amplitude 10-20 Hz [m/s^2]\n"
    )
    header = (
        f"{'f_n':>4s} {'zeta':>5s} {'variant':31s} {'RMS':>8s} {'RMS 1s':>8s} {'peak':>8s} "
        f"{'tip RMS':>8s} {'tip peak':>8s} {'band':>8s}"
    )
    print(header)
    for f, z in MODES:
        rows = {
            n: vibration_study(tr, robot, frequency_hz=f, damping_ratio=z)
            for n, (tr, robot) in plans.items()
        }
        for name, r in rows.items():
            print(
                f"{f:4.0f} {z:5.2f} {name:31s} {r.rms:8.4f} {r.rms_first_second:8.4f} "
                f"{r.peak:8.4f} {r.tip_rms:8.4f} {r.tip_peak:8.4f} {_band(r):8.5f}"
            )
        plain, smooth = rows[VARIANTS[0]], rows[VARIANTS[1]]
        print(
            f"{'':11s}{'ratio plain/smooth':31s} {plain.rms / smooth.rms:8.1f} "
            f"{plain.rms_first_second / smooth.rms_first_second:8.1f} "
            f"{plain.peak / smooth.peak:8.1f} {plain.tip_rms / smooth.tip_rms:8.2f} "
            f"{plain.tip_peak / smooth.tip_peak:8.2f} {_band(plain) / _band(smooth):8.1f}"
        )
    steps = {
        n: float(np.linalg.norm(vibration_study(tr, rb).ee_acceleration[0]))
        for n, (tr, rb) in plans.items()
    }
    print(
        "\nend-effector acceleration at t = 0 [m/s^2]: "
        + ", ".join(f"{n} {v:.3f}" for n, v in steps.items())
    )


if __name__ == "__main__":
    main()
