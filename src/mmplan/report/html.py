"""Assembly of the self-contained report page.

Order: the plain-language summary with every limit's margin (:mod:`.overview`), the 3D view,
the figures, then what only a specialist needs, folded away: the planner's internals (all of
summary.json), the resolved scenario and the papers cited. Everything is inline (CSS, the
meshcat viewer bundle, the page script, the figures as base64 PNG): the page loads nothing and
opens offline. A short script checks on load that every figure decoded and logs a console
error naming any that did not.
"""

from __future__ import annotations

import base64
import html
import json
from collections.abc import Mapping, Sequence
from importlib import resources
from importlib.util import find_spec
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

if TYPE_CHECKING:  # matplotlib and meshcat: imported only where figures and the 3D view are made
    from mmplan.report.figure_kit import RenderedFigure
    from mmplan.report.scene3d import Scene3D
    from mmplan.report.summary_rows import Overview

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

#: The papers cited in captions (docs/references.md).
REFERENCES = (
    ("PajakPajak", "G. Pająk, I. Pająk: Trajectory Planning for Mobile Manipulators with "
                   "Control Constraints."),
    ("Pajak", "G. Pająk: Trajectory planning for mobile manipulators with vibration reduction. "
              "Journal of Vibroengineering, 2021."),
    ("AbdessemedDjebrani", "F. Abdessemed, S. Djebrani: Trajectory Generation for Mobile "
                           "Manipulators. In: Robot Manipulators Trends and Development, "
                           "InTech, 2010."),
    ("JaniakTchon", "M. Janiak, K. Tchoń: Towards constrained motion planning of mobile "
                    "manipulators."),
    ("Nagatani", "K. Nagatani, T. Hirayama, A. Gofuku, Y. Tanaka: Motion Planning for Mobile "
                 "Manipulator with Keeping Manipulability. 2002."),
)

VIEWER_LEGEND = (
    "{robot} Red tube: the end effector's path; grey tube: the platform's path on the ground; "
    "green: the goal (or the reference path). Obstacles in their true shapes, numbered as in "
    "the figures. Ground grid: {step:g} m squares, labelled in metres; axes at the origin: "
    "x red, y green, z blue (0.5 m). Drag to orbit, right-drag to pan, wheel to zoom; "
    "\"Open Controls\" (top right) hides or shows any part of the scene."
)


def _css() -> str:
    return (resources.files("mmplan.report") / "report.css").read_text(encoding="utf-8")


def _package_text(package: str, name: str) -> str:
    """A data file of an installed package, found without importing the package (meshcat's
    ``__init__`` imports its server: 0.3 s)."""
    spec = find_spec(package)
    where = list(spec.submodule_search_locations or ()) if spec is not None else []
    if not where:  # pragma: no cover - the report extra checks its packages on import
        return (resources.files(package) / name).read_text(encoding="utf-8")
    return (Path(where[0]) / name).read_text(encoding="utf-8")


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


def _flat_rows(data: Mapping[str, Any], prefix: str = "") -> list[tuple[str, str, str]]:
    rows = []
    for key, value in data.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping):
            rows += _flat_rows(value, name + ".")
        elif isinstance(value, list):
            text = ", ".join(format_value(v) for v in value[:24])
            rows.append((name, text + (" ..." if len(value) > 24 else ""), name))
        else:
            rows.append((name, format_value(value), name))
    return rows


def internals(summary: Mapping[str, Any]) -> str:
    """summary.json as tables: the checker's keys, then the planner's own (``planner_info``)."""
    own = {k: v for k, v in summary.items() if k != "planner_info"}
    rows = _rows_html(_flat_rows(own))
    tables = f'<table class="summary"><caption>summary.json</caption>{rows}</table>'
    info = summary.get("planner_info")
    if isinstance(info, Mapping) and info:
        tables += ('<table class="summary"><caption>planner_info (the planner\'s own numbers)'
                   f"</caption>{_rows_html(_flat_rows(info, 'planner_info.'))}</table>")
    return f'<div class="tables">{tables}</div>'


def check_banner(summary: Mapping[str, Any]) -> str:
    """Red banner when summary.json records failed independent checks (else empty)."""
    if summary.get("check_passed") is not False:
        return ""
    failures = summary.get("check_failures")
    items = "".join(f"<li>{html.escape(str(f))}</li>" for f in failures or []
                    ) if isinstance(failures, list) else ""
    return ('<div class="check-failed"><b>The independent check FAILED</b> (mmplan check): '
            f"this plan is not valid as it stands.<ul>{items}</ul></div>")


def overview_html(view: Overview, summary: Mapping[str, Any]) -> str:
    """The opening: headline, key times and the limits table."""
    facts = "".join(f'<tr data-key="{html.escape(k)}"><th>{html.escape(label)}</th>'
                    f"<td>{html.escape(value)}</td></tr>" for label, value, k in view.facts)
    rows = []
    for r in view.limits:
        mark = "" if r.ok is None else ('<span class="ok">✓</span>' if r.ok
                                        else '<span class="bad">✗ broken</span>')
        rows.append(f'<tr data-key="{html.escape(r.key)}"><th>{html.escape(r.what)}</th>'
                    f"<td>{html.escape(r.worst)}</td><td>{html.escape(r.limit)}</td>"
                    f"<td>{html.escape(r.margin)} {mark}</td></tr>")
    limits = ('<table class="limits"><caption>Limits: how close the plan comes to each'
              "</caption><tr><th>limit</th><th>along the plan</th><th>limit</th>"
              f"<th>margin (closest approach)</th></tr>{''.join(rows)}</table>")
    return (f'<p class="headline">{html.escape(view.headline)}</p>{check_banner(summary)}'
            f'<div class="tables"><table class="summary facts">{facts}</table></div>{limits}')


def figure_block(fig: RenderedFigure) -> str:
    """One ``<figure>`` with the PNG inline."""
    data = base64.b64encode(fig.png).decode("ascii")
    return (
        f'<figure id="fig-{html.escape(fig.name)}"><img alt="{html.escape(fig.name)}" '
        f'src="data:image/png;base64,{data}"><figcaption><b>{html.escape(fig.title)}</b>'
        f"{html.escape(fig.caption)}</figcaption></figure>"
    )


def viewer_block(scene: Scene3D) -> str:
    """The 3D view: meshcat's viewer bundle, the commands, the page script and the controls."""
    data = {"commands": [base64.b64encode(c).decode("ascii") for c in scene.commands],
            "meta": scene.meta}
    scene_json = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    licence = _package_text("meshcat", "viewer/dist/main.min.js.LICENSE.txt").replace("*/", "* /")
    bundle = _package_text("meshcat", "viewer/dist/main.min.js")
    legend = VIEWER_LEGEND.format(step=scene.meta["grid_step"],
                                  robot=scene.meta.get("robot_legend", ""))
    options = "".join(f'<option value="{v}"{" selected" if v == "1" else ""}>{v}x</option>'
                      for v in ("0.25", "0.5", "1", "2", "4"))
    return (
        '<div id="mmplan-viewer"><div class="stage"><div class="pane"></div>'
        '<div class="labels"></div></div><div class="controls">'
        '<button class="play" type="button">Play</button>'
        '<input class="time" type="range" min="0" max="0" value="0" step="0.01" '
        'aria-label="time"><span class="clock"></span>'
        f'<label>speed <select class="speed">{options}</select></label>'
        '<label><input class="follow" type="checkbox" checked> follow the robot</label>'
        '<label><input class="points" type="checkbox"> collision model</label></div>'
        f'<p class="legend">{html.escape(legend)}</p>'
        '<div class="message"></div>'
        f'<script id="mmplan-scene" type="application/json">{scene_json}</script>'
        "<script>/*! 3D viewer: meshcat (MIT, github.com/meshcat-dev/meshcat), bundled with "
        f"three.js, dat.gui, msgpack-lite and others; their notices:\n{licence}*/\n"
        f"{bundle}</script><script>{_package_text('mmplan.report', 'viewer.js')}</script></div>"
    )


def references_block() -> str:
    """The papers cited by key (docs/references.md has the full entries)."""
    items = "".join(f"<li><b>[{key}]</b> {html.escape(text)}</li>" for key, text in REFERENCES)
    return f'<ul class="references">{items}</ul>'


def page(summary: Mapping[str, Any], scenario: Mapping[str, Any], view: Overview,
         figures: Sequence[RenderedFigure], viewer: str) -> str:
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
        f'<p class="sub">planner {planner} · robot {robot} · papers cited by key, listed at '
        'the end</p>'
        f'<section class="card" id="summary"><h2>Summary</h2>{overview_html(view, summary)}'
        "</section>"
        '<section class="card" id="view3d"><h2>The motion in 3D</h2>'
        f"{viewer}</section>"
        f'<h2>Figures</h2><div class="figures">{figs}</div>'
        '<details id="internals"><summary>Planner internals (summary.json: every number the '
        f"checker and the planner recorded)</summary>{internals(summary)}</details>"
        f"<details><summary>Scenario (resolved)</summary><pre>{scenario_text}</pre></details>"
        f"<details><summary>References</summary>{references_block()}</details>"
        "</main></body></html>\n"
    )
