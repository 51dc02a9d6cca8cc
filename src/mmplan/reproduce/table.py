"""REPRODUCTION.md and reproduction.html: the paper-vs-ours table of ``mmplan reproduce``.

Plain text and a small self-contained HTML page (inline CSS, no scripts, no external URL);
no plotting or HTML library.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import html
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import mmplan
from mmplan.errors import InputError
from mmplan.io.plan_folder import read_summary
from mmplan.reproduce.evaluate import Evaluated, Value
from mmplan.reproduce.runs import RunOutcome

HEADER = ("paper figure", "quantity", "paper", "ours", "difference", "verdict", "floor note")
#: What the floor notes mean (the papers have no floor; ours is an obstacle).
FLOOR_TEXT = ("Floor notes: the papers plan without a floor; in mmplan the ground z = 0 is an "
              "obstacle for every body whose height depends on the arm (docs/conventions.md, "
              "\"Floor\"). The extended-Jacobian paper scenarios are also planned without it "
              "(`ground: null`, runs `*-no-floor`); a row that reads one of them gives its value "
              "without the floor when the floor changes it, or says it does not.")
RUN_HEADER = ("scenario", "paper", "status", "T(tol)", "compute time", "wall time", "report")


def fmt_value(value: Value | None, unit: str) -> str:
    """A value with its unit: 4 significant digits; fractions in % times 100."""
    if value is None:
        return "-"
    if isinstance(value, str):
        return value
    if isinstance(value, tuple):
        return f"({value[0]:.3g}, {value[1]:.3g}) {unit}".strip()
    if unit == "%":
        return f"{100 * value:+.3g} %"
    if value.is_integer() and abs(value) >= 1000:
        return f"{int(value):,} {unit}".strip()
    return f"{value:.4g} {unit}".strip()


def fmt_difference(row: Evaluated) -> str:
    """ours - paper with its unit and relative size; the distance for points."""
    if row.delta is None:
        return ""
    unit = row.ref.unit
    if isinstance(row.ref.paper, tuple):
        return f"{row.delta:.3g} {unit} apart"
    if unit == "%":
        return f"{100 * row.delta:+.3g} points"
    text = f"{row.delta:+.3g} {unit}".strip()
    if row.rel is not None:
        text += f" ({100 * row.rel:+.3g} %)"
    return text


def link_of(run: RunOutcome | None) -> str | None:
    """Relative link to a run's report (its summary.json without a report)."""
    if run is None or not run.planned:
        return None
    if run.report is not None:
        return f"{run.spec.name}/report.html"
    return f"{run.spec.name}/summary.json"


def floor_note(row: Evaluated) -> str:
    """What the floor changes in a row (empty when it has no run without the floor)."""
    twin = row.without_floor
    if twin is None:
        return ""
    if not row.floor_changed:
        return "floor: no change (the same without it)"
    if twin.ours is None:
        return f"floor: without it {twin.verdict}"
    change = ""
    if isinstance(row.ours, float) and isinstance(twin.ours, float):
        delta = row.ours - twin.ours
        change = (f"{100 * delta:+.3g} points" if row.ref.unit == "%"
                  else f"{delta:+.3g} {row.ref.unit}".strip())
        change = f"; the floor changes it by {change}"
    return (f"floor: {fmt_value(twin.ours, row.ref.unit)} without it (ground: null, as in "
            f"the paper; verdict {twin.verdict}){change}")


def _cells(row: Evaluated) -> tuple[str, str, str, str, str, str]:
    return (row.ref.quantity, row.ref.paper_text or fmt_value(row.ref.paper, row.ref.unit),
            fmt_value(row.ours, row.ref.unit), fmt_difference(row), row.verdict,
            floor_note(row))


def _md_cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def markdown(runs: Sequence[RunOutcome], rows: Sequence[Evaluated], wall_s: float) -> str:
    """REPRODUCTION.md text: the reference table, the runs and the sources."""
    by_name = {r.spec.name: r for r in runs}
    lines = [
        "# Reproduction of the papers' numbers", "",
        f"`mmplan reproduce` (mmplan {mmplan.__version__}, "
        f"{dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M} UTC): {len(runs)} runs in {wall_s:.0f} s "
        "wall time. Paper values (papers cited by their keys in docs/references.md) and the "
        "values of the reference runs [RefRuns] are data in `mmplan/reproduce/published.py`; "
        "ours are read from each run's summary.json, scenario.yaml and trajectory.csv. Each "
        "quantity links to the run's report.", "",
        "| " + " | ".join(HEADER) + " |", "|" + "---|" * len(HEADER),
    ]
    for row in rows:
        quantity, paper, ours, diff, verdict, note = (_md_cell(c) for c in _cells(row))
        link = link_of(by_name.get(row.run))
        target = f"[{row.run}]({link})" if link else row.run
        lines.append(f"| {_md_cell(row.ref.figure)} | {quantity}, {target} | {paper} | {ours} "
                     f"| {diff} | {verdict} | {note} |")
    lines += ["", "## Runs", "", "| " + " | ".join(RUN_HEADER) + " |",
              "|" + "---|" * len(RUN_HEADER)]
    for run in runs:
        link = link_of(run)
        lines.append("| " + " | ".join(_md_cell(c) for c in _run_cells(run)) + " | "
                     + (f"[{'report' if run.report else 'summary'}]({link})" if link else "-")
                     + " |")
    lines += ["", "## Sources and notes", ""]
    if any(row.without_floor is not None for row in rows):
        lines += [FLOOR_TEXT, ""]
    for i, row in enumerate(rows, 1):
        note = f"{i}. {row.ref.figure}, {row.ref.quantity}: {row.ref.source}."
        if row.ref.known_gap:
            note += f" Expected difference: {row.ref.known_gap}."
        lines.append(note)
    for run in runs:
        if run.spec.note:
            lines.append(f"- `{run.spec.name}` (variant of `{run.spec.base}`): {run.spec.note}.")
        if run.status != "reached" or run.report_error:
            lines.append(f"- `{run.spec.name}`: {run.status}: {run.message}"
                         + (f"; report: {run.report_error}" if run.report_error else ""))
    return "\n".join(lines) + "\n"


def _run_cells(run: RunOutcome) -> tuple[str, ...]:
    summary: dict[str, Any] = {}
    if run.planned:
        with contextlib.suppress(InputError):
            summary = read_summary(run.directory)
    duration = summary.get("duration_s")
    compute = summary.get("compute_time_s")
    name = run.spec.name + (f" (variant of {run.spec.base})" if run.spec.base else "")
    return (name, run.spec.paper, run.status,
            f"{duration:.4g} s" if isinstance(duration, int | float) else "-",
            f"{compute:.3g} s" if isinstance(compute, int | float) else "-",
            f"{run.wall_time_s:.1f} s")


CSS = """body{font-family:system-ui,sans-serif;margin:2em;max-width:80em}
table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:.3em .6em;
text-align:left;vertical-align:top}th{background:#f3f3f3}.ok{background:#e6f4e6}
.bad{background:#fbe3e3}.exp{background:#fff4d6}li{margin:.2em 0}"""


def _css_class(verdict: str) -> str:
    if verdict.startswith(("matches", "holds")) and "(plan:" not in verdict:
        return "ok"
    if verdict.startswith(("differs (expected)", "within slack")):
        return "exp"
    return "bad"


def page(runs: Sequence[RunOutcome], rows: Sequence[Evaluated], wall_s: float) -> str:
    """reproduction.html: the same tables as :func:`markdown`, self-contained."""
    by_name = {r.spec.name: r for r in runs}
    e = html.escape

    def anchor(text: str, link: str | None) -> str:
        return f'<a href="{e(link)}">{e(text)}</a>' if link else e(text)

    body = [f"<h1>Reproduction of the papers' numbers</h1><p>mmplan {e(mmplan.__version__)}: "
            f"{len(runs)} runs in {wall_s:.0f} s wall time.</p><table><tr>"
            + "".join(f"<th>{e(h)}</th>" for h in HEADER) + "</tr>"]
    for row in rows:
        quantity, paper, ours, diff, verdict, note = _cells(row)
        link = link_of(by_name.get(row.run))
        body.append(f'<tr class="{_css_class(verdict)}"><td>{e(row.ref.figure)}</td><td>'
                    f"{e(quantity)}, {anchor(row.run, link)}</td><td>{e(paper)}</td><td>"
                    f"{e(ours)}</td><td>{e(diff)}</td><td>{e(verdict)}</td><td>{e(note)}"
                    "</td></tr>")
    body.append("</table><h2>Runs</h2><table><tr>"
                + "".join(f"<th>{e(h)}</th>" for h in RUN_HEADER) + "</tr>")
    for run in runs:
        cls = "ok" if run.status == "reached" else "bad"
        body.append(f'<tr class="{cls}">' + "".join(f"<td>{e(c)}</td>" for c in _run_cells(run))
                    + f"<td>{anchor('report' if run.report else 'summary', link_of(run))}"
                      "</td></tr>")
    body.append("</table><h2>Sources and notes</h2>")
    if any(row.without_floor is not None for row in rows):
        body.append(f"<p>{e(FLOOR_TEXT)}</p>")
    body.append("<ol>")
    body += [f"<li>{e(r.ref.figure)}, {e(r.ref.quantity)}: {e(r.ref.source)}"
             + (f". Expected difference: {e(r.ref.known_gap)}" if r.ref.known_gap else "")
             + "</li>" for r in rows]
    body.append("</ol><ul>")
    body += [f"<li>{e(r.spec.name)}: {e(r.status)}: {e(r.message)}</li>" for r in runs
             if r.status != "reached"]
    body.append("</ul>")
    return ("<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>mmplan "
            f"reproduction</title><style>{CSS}</style></head><body>{''.join(body)}</body></html>\n")


def write_tables(out: Path, runs: tuple[RunOutcome, ...], rows: tuple[Evaluated, ...],
                 wall_s: float) -> tuple[Path, Path]:
    """Write out/REPRODUCTION.md and out/reproduction.html; returns their paths."""
    md, page_path = out / "REPRODUCTION.md", out / "reproduction.html"
    try:
        md.write_text(markdown(runs, rows, wall_s), encoding="utf-8")
        page_path.write_text(page(runs, rows, wall_s), encoding="utf-8")
    except OSError as exc:
        raise InputError("--out", f"cannot write the tables into {out}: {exc.strerror}") from None
    return md, page_path
