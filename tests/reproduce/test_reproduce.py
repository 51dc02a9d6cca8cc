"""``mmplan reproduce``: runs, the paper-vs-ours table (rows, values, links), failures, and the
reference data (every row names real runs and keys; the checks judge numbers correctly)."""

from __future__ import annotations

import json
import math
import re
from collections.abc import Iterator
from html.parser import HTMLParser
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from click.testing import CliRunner, Result

import mmplan
from mmplan.cli.main import main
from mmplan.reproduce import run as repro
from mmplan.reproduce.evaluate import Evaluated, evaluate
from mmplan.reproduce.published import (
    REFERENCES,
    SCENARIOS,
    VARIANTS,
    Check,
    Measure,
    Op,
    Reference,
)
from mmplan.reproduce.runs import RunSpec
from mmplan.reproduce.table import HEADER, fmt_value

FAST = ("car-rtr-free", "wall-segment")


def run(*args: str) -> Result:
    return CliRunner().invoke(main, list(args))


def md_table(text: str, header: tuple[str, ...]) -> list[list[str]]:
    """Rows of the markdown table with this header (cells split on unescaped '|')."""
    lines = text.splitlines()
    start = lines.index("| " + " | ".join(header) + " |")
    assert re.fullmatch(r"\|(---\|)+", lines[start + 1]), lines[start + 1]
    rows = []
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        cells = [c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", line)[1:-1]]
        rows.append(cells)
    return rows


@pytest.fixture(scope="module")
def fast_repro(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Path, Result]]:
    """One reproduction of two fast scenarios, with reports (shared by the table tests)."""
    out = tmp_path_factory.mktemp("repro")
    yield out, run("reproduce", "--out", str(out), "--only", FAST[0], FAST[1])


def expected_refs(names: tuple[str, ...]) -> list[Reference]:
    return [r for r in REFERENCES if set(r.measure.runs) <= set(names)]


def test_fast_reproduction_writes_runs_reports_and_tables(
        fast_repro: tuple[Path, Result]) -> None:
    out, result = fast_repro
    assert result.exit_code == 0, result.output
    for name in FAST:
        assert (out / name / "summary.json").is_file() and (out / name / "report.html").is_file()
    assert not (out / "youbot3r-obstacles").exists()  # --only
    assert "numbers compared" in result.stdout and "REPRODUCTION.md" in result.stdout


def test_markdown_table_has_one_row_per_reference_with_links(
        fast_repro: tuple[Path, Result]) -> None:
    out, _ = fast_repro
    rows = md_table((out / "REPRODUCTION.md").read_text(), HEADER)
    refs = expected_refs(FAST)
    assert len(refs) >= 10 and len(rows) == len(refs)
    assert {r.figure.split()[0] for r in refs} >= {"[JaniakTchon]", "[Nagatani]", "[RefRuns]"}
    for cells, ref in zip(rows, refs, strict=True):
        assert len(cells) == len(HEADER)
        assert cells[0] == ref.figure and cells[1].startswith(ref.quantity)
        link = re.search(r"\[([^]]+)\]\(([^)]+)\)", cells[1])
        assert link is not None and link.group(1) == ref.measure.runs[0]
        assert link.group(2) == f"{ref.measure.runs[0]}/report.html"
        assert (out / link.group(2)).is_file()
        assert cells[3] != "-" and cells[5] and not cells[5].startswith("no value"), cells
    runs = md_table((out / "REPRODUCTION.md").read_text(), repro_run_header())
    assert [r[0] for r in runs] == list(FAST) and all(r[2] == "reached" for r in runs)


def repro_run_header() -> tuple[str, ...]:
    from mmplan.reproduce.table import RUN_HEADER
    return RUN_HEADER


def test_our_values_come_from_the_written_summaries(fast_repro: tuple[Path, Result]) -> None:
    out, _ = fast_repro
    rows = {c[1].split(", [")[0]: c for c in md_table((out / "REPRODUCTION.md").read_text(),
                                                        HEADER)}
    wall = json.loads((out / "wall-segment" / "summary.json").read_text())["planner_info"]
    car = json.loads((out / "car-rtr-free" / "summary.json").read_text())["planner_info"]
    assert rows["horizontal base path length"][3] == f"{wall['path_length_m']:.4g} m"
    assert rows["max |psi| without bounds"][3] == f"{car['max_abs.psi']:.4g} rad"
    start = rows["base path start (x, y)"]
    assert start[3] == fmt_value(tuple(wall["start_xy"]), "m")
    assert start[4] == f"{math.dist(wall['start_xy'], (0.27, 0.26)):.3g} m apart"
    assert rows["a straight base segment exists in the LMA"][3] == wall["path_kind"]
    # the free car steers far beyond pi/2 (6.57 rad in the reference runs [RefRuns])
    assert rows["max |psi| without bounds"][5] in ("holds", "matches")


class _Links(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.links: list[str] = []
        self.rows = 0
        self.srcs: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        if tag == "a" and a.get("href"):
            self.links.append(str(a["href"]))
        if tag == "tr":
            self.rows += 1
        if a.get("src"):
            self.srcs.append(str(a["src"]))


def test_html_page_has_the_same_rows_and_local_links(fast_repro: tuple[Path, Result]) -> None:
    out, _ = fast_repro
    text = (out / "reproduction.html").read_text()
    parser = _Links()
    parser.feed(text)
    refs = expected_refs(FAST)
    assert parser.rows == (len(refs) + 1) + (len(FAST) + 1)  # two tables with headers
    assert not parser.srcs and "http" not in text  # self-contained, offline
    assert set(parser.links) == {f"{n}/report.html" for n in FAST}
    assert all((out / link).is_file() for link in parser.links)
    assert "max |psi| without bounds" in text


def test_failed_scenario_is_a_row_and_exits_3(tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    real = repro.load_run

    def broken(spec: RunSpec) -> mmplan.Scenario:
        if spec.name == "car-rtr-free":
            raise ZeroDivisionError("planner bug")
        return real(spec)

    monkeypatch.setattr(repro, "load_run", broken)
    result = run("reproduce", "--out", str(tmp_path), "--no-report", *FAST)
    assert result.exit_code == 3, result.output
    assert "FAIL car-rtr-free" in result.stdout and "Traceback" not in result.output
    text = (tmp_path / "REPRODUCTION.md").read_text()
    runs = {r[0]: r for r in md_table(text, repro_run_header())}
    assert runs["car-rtr-free"][2] == "error" and runs["car-rtr-free"][6] == "-"
    assert runs["wall-segment"][2] == "reached"
    assert runs["wall-segment"][6] == "[summary](wall-segment/summary.json)"  # no report
    rows = md_table(text, HEADER)
    car = [r for r in rows if "car-rtr-free" in r[1]]
    assert car and all(r[5] == "no value: car-rtr-free failed to plan" for r in car)
    assert "internal error: ZeroDivisionError: planner bug" in text
    wall = [r for r in rows if "wall-segment" in r[1]]
    assert wall and not any(r[5].startswith("no value") for r in wall)


def test_unknown_name_exits_2(tmp_path: Path) -> None:
    result = run("reproduce", "--out", str(tmp_path / "o"), "--only", "car-rtr-fre")
    assert result.exit_code == 2
    assert result.stderr.startswith("error: --only: unknown scenario 'car-rtr-fre'; choose one")
    assert not (tmp_path / "o").exists()


def test_run_selection_and_variants() -> None:
    specs = repro.run_specs()
    assert [s.name for s in specs if s.base is None] == list(SCENARIOS)
    youbot = [n for n in SCENARIOS if n.startswith("youbot")]
    assert len(youbot) == 4 and all(n.endswith("-unlimited") for n in youbot)
    for name in youbot:  # the papers' robot: no velocity or acceleration limits
        assert not mmplan.load_scenario(name).build().robot.limits.rates.any
    limited = [s.name for s in repro.run_specs(["youbot3r-obstacles"])]
    assert limited == ["youbot3r-obstacles"]  # the real limits: run only when named
    assert {s.name for s in specs if s.base} == {v.name for v in VARIANTS}
    picked = [s.name for s in repro.run_specs(["diffdrive3-track,wall-segment"])]
    assert picked == ["diffdrive3-track", "diffdrive3-track-no-obstacle-term", "wall-segment"]


ROOT = Path(__file__).parents[2]
PAPER_KEYS = ("PajakPajak", "AbdessemedDjebrani", "JaniakTchon", "Pajak", "Nagatani")


def readme_methods() -> list[tuple[str, list[str]]]:
    """(paper cell, built-in scenarios) of each row of the README's method table; a listed
    scenario brings its papers' variant ``<name>-unlimited`` (the robot without rate limits)
    along, right after it, where one is built in."""
    rows = md_table((ROOT / "README.md").read_text(encoding="utf-8"),
                    ("method (`planner.method`)", "paper", "what it plans", "built-in scenarios"))
    builtin = mmplan.builtin_scenarios()
    out = []
    for cells in rows:
        names: list[str] = []
        for name in re.findall(r"`([a-z0-9-]+)`", cells[3]):
            for n in (name, f"{name}-unlimited"):
                if n not in names and (n == name or n in builtin):
                    names.append(n)
        out.append((cells[1], names))
    return out


def test_scenarios_are_the_built_in_paper_scenarios_of_the_readme() -> None:
    """SCENARIOS: the README's built-in scenarios in its order, less those without published
    numbers, each labelled with the paper (key, section) of its method's row. The youBot
    tasks are reproduced by their ``-unlimited`` variants (the papers' robot); the plain names
    hold the youBot's real rate limits and have no published numbers."""
    names = list(SCENARIOS)
    assert set(names) <= set(mmplan.builtin_scenarios())
    table = readme_methods()
    listed = [n for _, scenarios in table for n in scenarios]
    assert set(listed) == set(mmplan.builtin_scenarios())
    assert [n for n in listed if n in SCENARIOS] == names
    measured = {run for r in REFERENCES for run in r.measure.runs}
    for paper, scenarios in table:
        for name in scenarios:
            if name in SCENARIOS:
                label = SCENARIOS[name]
                assert re.fullmatch(rf"\[({'|'.join(PAPER_KEYS)})\]( s\.\d+)?", label), label
                assert label in paper and name in measured, (name, label, paper)
            else:  # a built-in extra with no published numbers
                assert name not in measured


def test_every_label_cites_a_paper_key_the_reference_runs_or_a_docs_page() -> None:
    keys = "|".join((*PAPER_KEYS, "RefRuns"))
    methods = {"extended-jacobian", "pseudoinverse", "impedance", "endogenous",
               "manipulability-area"}
    for ref in REFERENCES:
        assert re.match(rf"\[({keys})\] |docs/[a-z_]+\.md$", ref.figure), ref.figure
        cited = set(re.findall(r"\[([A-Z][A-Za-z]+)\]",  # "[s]" is a unit in a quote
                               f"{ref.figure} {ref.quantity} {ref.source}"))
        assert cited <= {*PAPER_KEYS, "RefRuns"}, ref
        if ref.figure.startswith("[RefRuns]"):  # "[RefRuns] <method>", the run named
            assert ref.figure.split()[1] in methods and "[RefRuns]" in ref.source, ref
        elif ref.figure.startswith("docs/"):
            assert ref.source.startswith(ref.figure), ref
        text = f"{ref.figure} {ref.quantity} {ref.source} {ref.known_gap}"
        assert not re.search(r"\b0{2}[0-4]\b", text), text  # papers by key, not by number


def test_cited_docs_exist_and_define_the_keys() -> None:
    """Every docs/ page the references cite exists; docs/references.md names every key."""
    docs = ROOT / "docs"
    if not docs.is_dir():
        pytest.skip("no docs/ folder next to the sources")
    texts = [f"{r.figure} {r.source} {r.known_gap}" for r in REFERENCES]
    pages = {p for t in texts for p in re.findall(r"docs/[a-z_]+\.md", t)}
    assert pages and all((ROOT / p).is_file() for p in pages), pages
    references = (docs / "references.md").read_text(encoding="utf-8")
    for key in (*PAPER_KEYS, "RefRuns"):
        assert re.search(rf"\b{key}\b", references), key


def test_variant_changes_only_its_planner_settings() -> None:
    spec = next(s for s in repro.run_specs(["omni3-impedance"]) if s.base)
    base, variant = mmplan.load_scenario("omni3-impedance"), repro.load_run(spec)
    a, b = base.resolved_dict(), variant.resolved_dict()
    assert b["name"] == spec.name and b["planner"]["b_obs"] == 0.0
    assert a["planner"]["b_obs"] > 0
    for key in ("robot", "start", "goal", "obstacles", "limits"):
        assert a[key] == b[key]


# ---- the reference data and the checks, on synthetic run folders ----------------------------

class FakeRun:
    def __init__(self, directory: Path, status: str = "reached") -> None:
        self.directory, self.status, self.planned = directory, status, True


def _put(tree: dict[str, Any], key: tuple[str, ...], value: Any) -> None:
    for part in key[:-1]:
        tree = tree.setdefault(part, {})
    tree[key[-1]] = list(value) if isinstance(value, tuple) else value


def fake_runs(root: Path, m: Measure, value: Any, status: str = "reached") -> dict[str, FakeRun]:
    """Run folders whose files make ``m`` evaluate to ``value``."""
    summaries: dict[str, dict[str, Any]] = {n: {"status": status} for n in m.runs}
    scenario: dict[str, Any] = {}
    first = summaries[m.runs[0]]
    if m.op is Op.VALUE:
        _put(first, m.key, value)
    elif m.op is Op.INCREASE:
        _put(first, m.key, 2.0)
        _put(summaries[m.runs[1]], m.key, 2.0 * (1.0 + value))
    elif m.op is Op.MINUS:
        _put(first, m.key, value + 0.05)
        if m.other[0] == "@scenario":
            _put(scenario, m.other[1:], 0.05)
        else:
            _put(first, m.other, 0.05)
    runs = {}
    for name in m.runs:
        folder = root / name
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "summary.json").write_text(json.dumps(summaries[name]))
        (folder / "scenario.yaml").write_text(yaml.safe_dump(scenario))
        runs[name] = FakeRun(folder, status)
    if m.op in (Op.COLUMN_MAX_ABS, Op.COLUMN_FIRST_ABS, Op.PLANAR_NORM_MAX):
        k = len(m.key)
        rows = {Op.COLUMN_FIRST_ABS: [[-value] * k, [value / 2] * k],
                Op.COLUMN_MAX_ABS: [[value / 2] * k, [-value] * k],
                Op.PLANAR_NORM_MAX: [[0.0, 0.0], [0.6 * value, 0.8 * value]]}[m.op]
        header = ["t", *m.key, "ee.x"]
        data = np.array([[i, *r, 0.0] for i, r in enumerate(rows)], dtype=float)
        np.savetxt(root / m.runs[0] / "trajectory.csv", data, delimiter=",",
                   header=",".join(header), comments="")
    return runs


def _off(ref: Reference) -> Any:
    """A value on the wrong side of ``ref``'s check by twice its tolerance."""
    p = ref.paper
    if isinstance(p, str):
        return p + "-other"
    scale = math.hypot(*p) if isinstance(p, tuple) else abs(p)
    step = 2 * (ref.tol * scale if ref.relative else ref.tol) + 1e-3 * max(scale, 1e-3)
    if isinstance(p, tuple):
        return (p[0] + step, p[1])
    return p - step if ref.check is Check.AT_LEAST else p + step


@pytest.mark.parametrize("ref", REFERENCES, ids=lambda r: f"{r.figure} {r.quantity}")
def test_every_reference_judges_the_paper_value_and_a_wrong_one(tmp_path: Path,
                                                                ref: Reference) -> None:
    known = {s.name for s in repro.run_specs()}
    assert set(ref.measure.runs) <= known and ref.source, ref
    good = evaluate(ref, fake_runs(tmp_path / "good", ref.measure, ref.paper))
    assert good.verdict in ("matches", "holds"), good
    assert good.delta is None or abs(good.delta) < 1e-9 * max(1.0, abs(good.delta))
    bad = evaluate(ref, fake_runs(tmp_path / "bad", ref.measure, _off(ref)))
    assert bad.verdict in ("differs", "differs (expected)", "violated"), bad
    assert (bad.verdict == "differs (expected)") == (ref.check is Check.CLOSE
                                                      and bool(ref.known_gap))


def _ref(check: Check, paper: float = 1.0, tol: float = 0.1, **kw: Any) -> Reference:
    return Reference("T", "q", paper, "m", Measure(("r",), ("v",)), check, tol, **kw)


@pytest.mark.parametrize(("check", "ours", "verdict"), [
    (Check.CLOSE, 1.09, "matches"), (Check.CLOSE, 0.89, "differs"),
    (Check.AT_MOST, 0.5, "holds"), (Check.AT_MOST, 1.05, "within slack"),
    (Check.AT_MOST, 1.2, "violated"), (Check.AT_LEAST, 1.5, "holds"),
    (Check.AT_LEAST, 0.95, "within slack"), (Check.AT_LEAST, 0.8, "violated"),
])
def test_check_rules(tmp_path: Path, check: Check, ours: float, verdict: str) -> None:
    ref = _ref(check)
    row = evaluate(ref, fake_runs(tmp_path, ref.measure, ours))
    assert row.verdict == verdict and row.delta == pytest.approx(ours - 1.0)
    assert row.rel == pytest.approx(ours - 1.0)


def test_absolute_tolerance_and_unreached_status(tmp_path: Path) -> None:
    ref = _ref(Check.CLOSE, paper=100.0, tol=0.5, relative=False)
    assert evaluate(ref, fake_runs(tmp_path / "a", ref.measure, 100.4)).verdict == "matches"
    row = evaluate(ref, fake_runs(tmp_path / "b", ref.measure, 100.6, status="timeout"))
    assert row.verdict == "differs (plan: timeout)" and row.statuses == ("timeout",)


@pytest.mark.parametrize(("summary", "why"), [
    ({}, "no value: r: no v"),
    ({"v": None}, "no value: r: v is null"),
    ({"v": "nan"}, "no value: r: v = 'nan'"),
])
def test_missing_values_are_named(tmp_path: Path, summary: dict[str, Any], why: str) -> None:
    (tmp_path / "r").mkdir()
    (tmp_path / "r" / "summary.json").write_text(json.dumps(summary))
    row: Evaluated = evaluate(_ref(Check.CLOSE), {"r": FakeRun(tmp_path / "r")})
    assert row.ours is None and row.verdict == why
    assert evaluate(_ref(Check.CLOSE), {}).verdict == "no value: r not run"


def test_paper_numbers_are_the_printed_ones() -> None:
    """The papers' seconds ([PajakPajak]: 44.6 / 49.4, [Pajak]: 7.13 / 7.34) and ratios."""
    by = {(r.figure, r.quantity): r.paper for r in REFERENCES}
    times = [v for (fig, q), v in by.items()
             if fig in ("[PajakPajak] s.5", "[Pajak] s.5") and q.startswith("T(1 mm)")]
    assert times == [44.6, 49.4, 7.13, 7.34]
    ratios = [v for (fig, q), v in by.items() if q == "time added by the torque limits"]
    assert ratios == pytest.approx([0.1076, 0.0295], abs=1e-4)


def test_progress_is_monotone_and_ends_at_the_run_count(tmp_path: Path) -> None:
    calls: list[tuple[str, float, int]] = []
    result = repro.reproduce(tmp_path, ["car-rtr-free"], report=False,
                             progress=lambda *a: calls.append(a))
    done = [c[1] for c in calls]
    assert done == sorted(done) and done[0] == 0.0 and calls[-1] == ("car-rtr-free", 1.0, 1)
    assert len(calls) > 3  # the planner's own progress passes through
    assert not result.failed and [r.status for r in result.runs] == ["reached"]
    assert result.markdown.is_file() and result.html.is_file()
