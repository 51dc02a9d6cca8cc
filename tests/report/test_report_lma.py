"""Report figures of the manipulability-area planner ([Nagatani] Figs. 3, 4, 5, 8) and of the
tip vibration ([Pajak] Fig. 9): drawn from a real wall-segment plan and from small hand-made arrays,
checked against the plan's own files and closed forms."""

from __future__ import annotations

import base64
import io
import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from matplotlib.image import imread

from mmplan.cli.main import main
from mmplan.report.figures_method import artifact_figures
from mmplan.report.lma_data import read_lma

LMA_FIGURES = ("lma_distribution", "lma_ring", "lma_layers_3d", "lma_top_view")


def _pixels(png: bytes) -> np.ndarray:
    return imread(io.BytesIO(png), format="png")


def _ink(png: bytes) -> float:
    """Fraction of pixels that are not (nearly) white."""
    rgb = _pixels(png)[:, :, :3]
    return float((rgb.min(axis=2) < 0.9).mean())


def _sine_spectrum(f0: float = 15.0, amplitude: float = 0.2) -> dict[str, np.ndarray]:
    """One-sided amplitude spectrum of a sine of ``amplitude`` at ``f0`` (on a bin), 2 s at
    200 Hz, with a small broadband floor; RMS of the sine is amplitude / sqrt(2)."""
    dt, n = 0.005, 400
    t = np.arange(n) * dt
    rng = np.random.default_rng(7)
    signal = amplitude * np.sin(2 * np.pi * f0 * t) + 1e-4 * rng.standard_normal(n)
    amp = np.abs(np.fft.rfft(signal)) / n
    amp[1 : (n + 1) // 2] *= 2.0
    return {
        "vibration_freq_hz": np.fft.rfftfreq(n, dt),
        "vibration_amplitude": amp,
        "vibration_amplitude_x": 0.5 * amp,
        "vibration_rms": np.array([np.sqrt(np.mean(signal**2))]),
        "vibration_time_s": t,
        "vibration_acceleration_norm": np.abs(signal),
    }


@pytest.fixture(scope="module")
def lma_plan(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``mmplan plan wall-segment`` through the CLI, then ``mmplan report`` on it, with a
    vibration spectrum added to its artifacts.npz (both method figures in one report)."""
    folder = tmp_path_factory.mktemp("lma") / "plan"
    planned = CliRunner().invoke(main, ["plan", "wall-segment", "--out", str(folder)])
    assert planned.exit_code == 0, planned.output
    with np.load(folder / "artifacts.npz") as npz:
        arrays = {k: npz[k] for k in npz.files}
    arrays.update(_sine_spectrum())
    np.savez(folder / "artifacts.npz", allow_pickle=False, **arrays)
    reported = CliRunner().invoke(main, ["report", str(folder)])
    assert reported.exit_code == 0, reported.output
    return folder


def test_report_shows_the_four_lma_figures_and_the_spectrum(lma_plan: Path) -> None:
    html = (lma_plan / "report.html").read_text()
    pngs = {p.stem for p in (lma_plan / "figures").glob("*.png")}
    for name in (*LMA_FIGURES, "vibration_spectrum"):
        assert name in pngs
        raw = (lma_plan / "figures" / f"{name}.png").read_bytes()
        assert raw[:8] == b"\x89PNG\r\n\x1a\n"
        assert base64.b64encode(raw).decode() in html
        assert f'id="fig-{name}"' in html
        assert _ink(raw) > 0.05  # something is drawn
    # the generic drawing no longer handles these arrays
    assert not any(p.startswith("artifact_") for p in pngs), pngs


def test_lma_record_matches_the_plan_files(lma_plan: Path) -> None:
    summary = json.loads((lma_plan / "summary.json").read_text())
    info = summary["planner_info"]
    with np.load(lma_plan / "artifacts.npz") as npz:
        data = read_lma({k: npz[k] for k in npz.files})
    assert data is not None
    assert data.threshold == pytest.approx(summary["manipulability_threshold"], rel=1e-12)
    assert data.layers == info["layers"] == 31
    assert data.masks[0].size == info["cells_per_layer"] == 22100
    assert int(data.masks.sum(axis=(1, 2)).min()) == info["ma_cells_min"]
    assert np.allclose(data.path_xy[0], info["start_xy"]) and np.allclose(
        data.path_xy[-1], info["end_xy"]
    )
    # the MA is the thresholded distribution (first layer)
    assert np.array_equal(data.masks[0], data.w_first >= data.threshold)
    length = np.linalg.norm(np.diff(data.path_rows, axis=0), axis=1).sum()
    assert length == pytest.approx(info["path_length_m"], rel=1e-9)
    # the wall x = 0 of the scenario (normal +x, towards the base) is recovered from the tool
    wall = data.wall_line()
    assert wall is not None
    point, normal = wall
    assert point[0] == pytest.approx(0.0, abs=1e-12)
    assert np.allclose(normal, [1.0, 0.0])
    # every planned base lies in its layer's MA cell (nearest grid cell)
    ix = np.rint((data.path_xy[:, 0] - data.xs[0]) / (data.xs[1] - data.xs[0])).astype(int)
    iy = np.rint((data.path_xy[:, 1] - data.ys[0]) / (data.ys[1] - data.ys[0])).astype(int)
    assert data.masks[np.arange(data.layers), ix, iy].all()


def _ring_artifacts(
    layers: int = 5, subgoals: tuple[int, ...] = (0, 2, 4)
) -> dict[str, np.ndarray]:
    """Hand-made rings: w peaks at distance 0.3 from the tool point, which moves along a
    stroke on the wall y = 0.5 (base side y < 0.5)."""
    xs, ys = np.linspace(-0.5, 0.5, 41), np.linspace(-0.3, 0.45, 31)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    s = np.linspace(0.0, 1.0, layers)
    tool = np.column_stack([np.linspace(-0.1, 0.1, layers), np.full(layers, 0.5), 0.4 + 0 * s])
    w = np.stack([np.exp(-(((np.hypot(X - tx, Y - ty) - 0.3) / 0.08) ** 2)) for tx, ty, _ in tool])
    threshold = 0.5
    path = np.column_stack([tool[:, 0], np.full(layers, 0.22)])
    return {
        "grid_x": xs,
        "grid_y": ys,
        "layer_s": s,
        "tool_positions": tool,
        "manipulability_first": w[0],
        "manipulability_last": w[-1],
        "ma_masks": (w >= threshold).astype(float),
        "path_xy": path,
        "subgoal_layers": np.asarray(subgoals, dtype=float),
        "threshold": np.array([threshold]),
        "extra_series_time": np.linspace(0.0, 1.0, 7),
        "extra_series": np.linspace(1.0, 2.0, 7),
    }


def test_hand_made_rings_draw_lma_figures_and_keep_the_rest_generic() -> None:
    arrays = _ring_artifacts()
    data = read_lma(arrays)
    assert data is not None
    assert list(data.subgoals) == [0, 2, 4]
    wall = data.wall_line()
    assert wall is not None and np.allclose(wall[1], [0.0, -1.0])  # base side y < 0.5
    figures = {f.name: f for f in artifact_figures(arrays)}
    assert set(LMA_FIGURES) <= set(figures)
    assert "sub-goals at layers 2" in figures["lma_layers_3d"].caption
    assert "artifact_extra_series_time" in figures  # other arrays: generic drawing
    assert not any(n.startswith("artifact_") and "ma_masks" in n for n in figures)


def test_inconsistent_lma_arrays_fall_back_to_the_generic_drawing() -> None:
    arrays = _ring_artifacts()
    arrays["ma_masks"] = arrays["ma_masks"][:, :-1]  # wrong grid shape
    assert read_lma(arrays) is None
    names = {f.name for f in artifact_figures(arrays)}
    assert not names & set(LMA_FIGURES)
    assert "artifact_ma_masks" in names


def test_vertical_stroke_wall_faces_the_manipulability_area() -> None:
    arrays = _ring_artifacts()
    tool = arrays["tool_positions"].copy()
    tool[:, :2] = [0.0, 0.5]  # the tool only moves up: the wall's side comes from the MA
    tool[:, 2] = np.linspace(0.3, 0.6, len(tool))
    arrays["tool_positions"] = tool
    data = read_lma(arrays)
    assert data is not None
    wall = data.wall_line()
    assert wall is not None
    ix, iy = np.nonzero(data.masks[0])
    centre = np.array([data.xs[ix].mean(), data.ys[iy].mean()])
    expected = (centre - [0.0, 0.5]) / np.linalg.norm(centre - [0.0, 0.5])
    assert np.allclose(wall[1], expected)


def test_spectrum_figure_names_peak_and_rms() -> None:
    arrays = _sine_spectrum(f0=15.0, amplitude=0.2)
    figures = {f.name: f for f in artifact_figures(arrays)}
    assert set(figures) == {"vibration_spectrum"}  # no generic spectrum of the same arrays
    caption = figures["vibration_spectrum"].caption
    assert "15.00 Hz" in caption  # the sine's frequency (bin 30 of 2 s)
    rms = float(arrays["vibration_rms"][0])
    assert rms == pytest.approx(0.2 / np.sqrt(2), rel=1e-3)  # closed form of a sine's RMS
    assert f"RMS over the record {rms:.4g} m/s^2" in caption
    assert _ink(figures["vibration_spectrum"].png) > 0.03


def test_spectrum_without_time_series_or_rms() -> None:
    full = _sine_spectrum(f0=40.0)
    arrays = {k: full[k] for k in ("vibration_freq_hz", "vibration_amplitude")}
    figures = artifact_figures(arrays)
    assert [f.name for f in figures] == ["vibration_spectrum"]
    assert "40.00 Hz" in figures[0].caption and "RMS" not in figures[0].caption
    tall = _pixels(artifact_figures(full)[0].png).shape[0]
    assert _pixels(figures[0].png).shape[0] < tall  # one panel instead of two
