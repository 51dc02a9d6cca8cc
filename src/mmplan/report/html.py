"""Assembly of the self-contained report page: summary table, 3D viewer, figures.

Everything is inline (CSS, the viewer script, figures as base64 PNG): the page references no
URL and opens offline. A short script checks on load that every figure decoded and logs a
console error naming any that did not.
"""

from __future__ import annotations

import base64
import html
from collections.abc import Mapping, Sequence
from importlib import resources
from typing import Any

import yaml

from mmplan.report.figure_kit import RenderedFigure

CHECK_SCRIPT = """
window.addEventListener("load", function () {
  var images = document.querySelectorAll("figure img"), ok = 0;
  images.forEach(function (img) {
    if (img.complete && img.naturalWidth > 0) ok += 1;
    else console.error("mmplan report: figure " + img.alt + " failed to load");
  });
  document.body.dataset.figuresLoaded = String(ok);
});
"""

SUMMARY_ROWS: tuple[tuple[str, str, str], ...] = (
    ("status", "Status", ""),
    ("planner", "Planner", ""),
    ("robot", "Robot", ""),
    ("duration_s", "T (scenario tolerance)", "s"),
    ("duration_1cm_s", "T (1 cm)", "s"),
    ("duration_1mm_s", "T (1 mm)", "s"),
    ("final_error_m", "Final error", "m"),
    ("min_clearance_m", "Minimal clearance", "m"),
    ("max_joint_limit_violation", "Max joint-limit violation", ""),
    ("max_torque_violation", "Max torque violation", ""),
    ("max_pfaffian_residual", "Max Pfaffian residual |A(q) dq|", ""),
    ("manipulability_start", "Manipulability (start)", ""),
    ("manipulability_end", "Manipulability (end)", ""),
    ("manipulability_min", "Manipulability (min)", ""),
    ("compute_time_s", "Compute time", "s"),
    ("samples", "Samples", ""),
    ("message", "Message", ""),
)


def _css() -> str:
    return (resources.files("mmplan.report") / "report.css").read_text(encoding="utf-8")


def format_value(value: Any, unit: str = "") -> str:
    """A summary value as text: ``-`` for null, 4 significant digits for floats."""
    if value is None:
        return "–"
    if isinstance(value, bool):
        return "yes" if value else "no"
    text = f"{value:.4g}" if isinstance(value, float) else str(value)
    return f"{text} {unit}".strip()


def _rows_html(rows: Sequence[tuple[str, str, str]]) -> str:
    return "".join(
        f'<tr data-key="{html.escape(k)}"><th>{html.escape(label)}</th>'
        f"<td>{html.escape(text)}</td></tr>"
        for label, text, k in rows
    )


def summary_table(summary: Mapping[str, Any]) -> str:
    """HTML tables: the summary keys (docs/conventions.md) and further scalar keys, then the
    planner's own numbers (``planner_info``) beside them."""
    rows = []
    for key, label, unit in SUMMARY_ROWS:
        if key in summary:
            rows.append((label, format_value(summary[key], unit), key))
    known = {k for k, _, _ in SUMMARY_ROWS} | {"planner_info"}
    for key, value in summary.items():
        if key not in known and isinstance(value, str | int | float | type(None)):
            rows.append((key, format_value(value), key))
    info_rows = []
    info = summary.get("planner_info")
    if isinstance(info, Mapping):
        for key, value in info.items():
            if isinstance(value, list) and len(value) <= 12:
                text = ", ".join(format_value(v) for v in value)
                info_rows.append((key, text, f"planner_info.{key}"))
            elif isinstance(value, str | int | float | bool | type(None)):
                info_rows.append((key, format_value(value), f"planner_info.{key}"))
    tables = f'<table class="summary">{_rows_html(rows)}</table>'
    if info_rows:
        tables += (
            '<table class="summary info"><caption>planner info</caption>'
            f"{_rows_html(info_rows)}</table>"
        )
    return f'{_check_banner(summary)}<div class="tables">{tables}</div>'


def _check_banner(summary: Mapping[str, Any]) -> str:
    """Red banner when summary.json records failed independent checks (else empty)."""
    if summary.get("check_passed") is not False:
        return ""
    failures = summary.get("check_failures")
    items = "".join(f"<li>{html.escape(str(f))}</li>" for f in failures or []
                    ) if isinstance(failures, list) else ""
    return (
        '<div class="check-failed" style="background:#c5221f;color:#fff;padding:8px 12px;'
        'border-radius:6px;margin:0 0 10px"><b>The independent check FAILED</b> '
        f"(mmplan check): this plan is not valid as it stands.<ul>{items}</ul></div>"
    )


def figure_block(fig: RenderedFigure) -> str:
    """One ``<figure>`` with the PNG inline."""
    data = base64.b64encode(fig.png).decode("ascii")
    return (
        f'<figure id="fig-{html.escape(fig.name)}"><img alt="{html.escape(fig.name)}" '
        f'src="data:image/png;base64,{data}"><figcaption><b>{html.escape(fig.title)}</b>'
        f"{html.escape(fig.caption)}</figcaption></figure>"
    )


def viewer_block(scene_json: str, script: str) -> str:
    """The 3D viewer's markup, its data and its script."""
    return (
        '<div id="mmplan-viewer"><canvas></canvas><div class="controls">'
        '<button class="play" type="button">Play</button>'
        '<input type="range" min="0" max="0" value="0" step="1" aria-label="time">'
        '<span class="time"></span><label>speed <select class="speed">'
        '<option value="0.25">0.25x</option><option value="0.5">0.5x</option>'
        '<option value="1" selected>1x</option><option value="2">2x</option>'
        '<option value="4">4x</option><option value="8">8x</option></select></label></div>'
        '<p class="legend">black: links; dots: collision points; red: end effector; orange: '
        "its path; grey: platform path; green cross: goal; wireframes: obstacle models</p>"
        '<div class="message"></div>'
        f'<script id="mmplan-scene" type="application/json">{scene_json}</script>'
        f"<script>{script}</script></div>"
    )


def page(
    summary: Mapping[str, Any],
    scenario: Mapping[str, Any],
    figures: Sequence[RenderedFigure],
    viewer: str,
) -> str:
    """The whole report page."""
    status = str(summary.get("status", "unknown"))
    badge = "reached" if status == "reached" else "other"
    name = html.escape(str(scenario.get("name", "plan")))
    method = (scenario.get("planner") or {}).get("method", "")
    planner = html.escape(str(summary.get("planner", method)))
    robot = html.escape(str(scenario.get("robot", "")))
    scenario_text = html.escape(yaml.safe_dump(dict(scenario), sort_keys=False))
    figs = "".join(figure_block(f) for f in figures)
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>mmplan report: {name}</title><style>{_css()}</style>"
        f"<script>{CHECK_SCRIPT}</script></head><body><main>"
        f'<h1>{name} <span class="badge {badge}">{html.escape(status)}</span></h1>'
        f'<p class="sub">planner {planner} · robot {robot}</p>'
        f'<section class="card"><h2>Summary</h2>{summary_table(summary)}</section>'
        '<section class="card"><h2>3D animation</h2><p class="sub">Drag to orbit, wheel to '
        f"zoom, double-click to reset.</p>{viewer}</section>"
        f'<h2>Figures</h2><div class="figures">{figs}</div>'
        f"<details><summary>Scenario (resolved)</summary><pre>{scenario_text}</pre></details>"
        "</main></body></html>\n"
    )
