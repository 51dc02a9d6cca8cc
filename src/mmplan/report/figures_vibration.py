"""Tip-vibration figure ([Pajak] Figs. 8, 9): acceleration spectrum and its time series.

Drawn from the arrays :func:`mmplan.analysis.vibration.vibration_artifacts` writes to artifacts.npz:
``vibration_freq_hz`` (F,) with ``vibration_amplitude`` (F,) (root-sum-square over the axes)
and/or ``vibration_amplitude_x/_y/_z``; optionally ``vibration_time_s`` with
``vibration_acceleration_norm`` (the time series) and ``vibration_rms`` (shown in the title).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from matplotlib.figure import Figure

from mmplan.arrays import Array
from mmplan.report.figure_kit import DPI, RenderedFigure, legend_outside, log_y, render

FREQ = "vibration_freq_hz"
TOTAL = "vibration_amplitude"
AXES = ("x", "y", "z")
TIME, NORM, RMS = "vibration_time_s", "vibration_acceleration_norm", "vibration_rms"
VIBRATION_KEYS = (FREQ, TOTAL, *(f"{TOTAL}_{a}" for a in AXES), TIME, NORM, RMS)
#: Plain text: mathtext (``$^2$``) builds its parser on first use, 0.1-0.2 s of a report.
UNIT = "m/s\N{SUPERSCRIPT TWO}"


def _series(arrays: Mapping[str, np.ndarray], length: int) -> dict[str, Array]:
    """Amplitude spectra of the right length: per axis, then the total (label -> values)."""
    out: dict[str, Array] = {}
    for axis in AXES:
        values = arrays.get(f"{TOTAL}_{axis}")
        if values is not None and np.shape(values) == (length,):
            out[f"{axis} axis"] = np.asarray(values, dtype=float)
    total = arrays.get(TOTAL)
    if total is not None:
        total = np.asarray(total, dtype=float)
        if total.shape == (length,):
            out["total (root-sum-square)"] = total
        elif total.ndim == 2 and total.shape[0] == length and total.shape[1] <= 3:
            for i in range(total.shape[1]):
                out.setdefault(f"{AXES[i]} axis", total[:, i])
    return out


def _rms(arrays: Mapping[str, np.ndarray]) -> float | None:
    value = arrays.get(RMS)
    if value is None or np.size(value) != 1:
        return None
    rms = float(np.asarray(value, dtype=float).ravel()[0])
    return rms if np.isfinite(rms) else None


def _time_series(arrays: Mapping[str, np.ndarray]) -> tuple[Array | None, Array | None]:
    """|vibration acceleration| over time, when both arrays are present and consistent."""
    if TIME not in arrays or NORM not in arrays:
        return None, None
    time, norm = (np.asarray(arrays[k], dtype=float) for k in (TIME, NORM))
    if time.ndim != 1 or time.shape != norm.shape or time.size < 2:
        return None, None
    return time, norm


def vibration_figure(arrays: Mapping[str, np.ndarray]) -> RenderedFigure | None:
    """Amplitude spectrum of the tip's vibration acceleration (and its magnitude over time when
    present), or None when artifacts.npz has no spectrum."""
    if FREQ not in arrays or np.ndim(arrays[FREQ]) != 1:
        return None
    freq = np.asarray(arrays[FREQ], dtype=float)
    series = _series(arrays, len(freq))
    if len(freq) < 2 or not series:
        return None
    time, norm = _time_series(arrays)
    timed = time is not None and norm is not None
    fig = Figure(figsize=(7.4, 5.8 if timed else 3.8), dpi=DPI, layout=None)
    axes = fig.subplots(2 if timed else 1, 1, squeeze=False)[:, 0]
    ax = axes[0]
    for label, values in series.items():
        total = label.startswith("total")
        ax.plot(
            freq,
            values,
            label=label,
            lw=1.6 if total else 0.9,
            color="black" if total else None,
            alpha=1.0 if total else 0.8,
        )
    totals = [v for k, v in series.items() if k.startswith("total")]
    main = totals[0] if totals else np.sqrt(np.sum([v**2 for v in series.values()], axis=0))
    positive = main[1:][main[1:] > 0] if len(main) > 1 else main[main > 0]
    if positive.size and positive.max() > 100 * positive.min():
        log_y(ax)
        ax.set_ylim(bottom=max(positive.min(), positive.max() * 1e-6))
    peak = int(np.argmax(main[1:]) + 1) if len(main) > 1 else 0
    ax.axvline(
        freq[peak],
        color="tab:red",
        ls="--",
        lw=1.0,
        label=f"peak {freq[peak]:.1f} Hz, {main[peak]:.3g} {UNIT}",
    )
    ax.set_xlim(freq[0], freq[-1])
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel(f"amplitude [{UNIT}]")
    ax.grid(True, which="both", alpha=0.3)
    legend_outside(ax)
    rms = _rms(arrays)
    title = "Tip vibration acceleration spectrum"
    ax.set_title(title + (f", RMS = {rms:.4g} {UNIT}" if rms is not None else ""), fontsize=10)
    if time is not None and norm is not None:
        axes[1].plot(time, norm, lw=0.8, color="tab:blue")
        axes[1].set_xlabel("time t [s]")
        axes[1].set_ylabel(f"|vibration acc.| [{UNIT}]")
        axes[1].grid(True, alpha=0.3)
        axes[1].set_title("Magnitude of the tip's vibration acceleration over time", fontsize=10)
    caption = (
        f"One-sided amplitude spectrum of the tip's vibration acceleration ([Pajak] Fig. 9); "
        f"largest component at {freq[peak]:.2f} Hz"
        + (f"; RMS over the record {rms:.4g} m/s^2" if rms is not None else "")
        + ("; below: its magnitude over time ([Pajak] Fig. 8)." if timed else ".")
    )
    return render(fig, "vibration_spectrum", "Tip vibration ([Pajak] Figs. 8, 9)", caption)
