"""``mmplan reproduce``: plan every built-in paper scenario and compare with the papers.

Runs the scenarios of :data:`mmplan.reproduce.published.SCENARIOS` (and the variants the references
compare against), writes each plan to ``OUT/<name>/`` (:func:`mmplan.write_plan`) with its
report, then evaluates every :data:`~mmplan.reproduce.published.REFERENCES` row from the written
files
and writes ``OUT/REPRODUCTION.md`` and ``OUT/reproduction.html``
(:mod:`mmplan.reproduce.table`). A scenario that fails is recorded with its status, never raised.
No CLI or plotting imports: progress goes to a callback; the report module (optional extra)
is imported only when reports are asked for.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import yaml

from mmplan.analysis import analyse
from mmplan.errors import InputError, MmplanError
from mmplan.io.plan_folder import write_plan
from mmplan.planners import get_planner
from mmplan.reproduce.evaluate import Evaluated, evaluate
from mmplan.reproduce.published import REFERENCES, SCENARIOS, VARIANTS, Reference
from mmplan.reproduce.runs import RunOutcome, RunSpec
from mmplan.scenario.loader import Scenario, builtin_scenarios, load_scenario

#: progress(run name, runs finished + fraction of the current run, number of runs)
ProgressFn = Callable[[str, float, int], None]


@dataclass(frozen=True)
class Reproduction:
    """Result of :func:`reproduce`: the runs, the evaluated rows and the written tables."""

    out_dir: Path
    runs: tuple[RunOutcome, ...]
    rows: tuple[Evaluated, ...]
    markdown: Path
    html: Path
    wall_time_s: float

    @property
    def failed(self) -> tuple[RunOutcome, ...]:
        """Built-in scenarios that did not reach their task (variants are not counted)."""
        return tuple(r for r in self.runs if r.spec.base is None and r.status != "reached")


def run_specs(only: Iterable[str] = ()) -> tuple[RunSpec, ...]:
    """The runs to make, in order; ``only`` selects scenarios (their variants come along) and
    may also name the built-in scenarios that have no paper numbers (run only when named).

    Raises:
        InputError: a name in ``only`` is neither a paper scenario nor a variant.
    """
    specs: list[RunSpec] = []
    for name, paper in SCENARIOS.items():
        specs.append(RunSpec(name, paper))
        specs += [RunSpec(v.name, paper, v.base, dict(v.planner), v.note)
                  for v in VARIANTS if v.base == name]
    wanted = [n.strip() for item in only for n in item.split(",") if n.strip()]
    if not wanted:
        return tuple(specs)
    # built-in scenarios without paper numbers run only when named (e.g. wall-segment-limits)
    specs += [RunSpec(name, "") for name in builtin_scenarios() if name not in SCENARIOS]
    known = [s.name for s in specs]
    for name in wanted:
        if name not in known:
            raise InputError("--only", f"unknown scenario {name!r}; choose one of "
                                       f"{', '.join(known)}")
    return tuple(s for s in specs
                 if s.name in wanted or (s.base is not None and s.base in wanted))


def load_run(spec: RunSpec) -> Scenario:
    """The scenario of a run (a variant: the base file with its planner settings replaced)."""
    if spec.base is None:
        return load_scenario(spec.name)
    path = builtin_scenarios()[spec.base]
    data = yaml.safe_load(path.read_text(encoding="utf-8"))
    data["name"] = spec.name
    data["planner"] = {**data["planner"], **(spec.planner or {})}
    return Scenario.from_dict(data, source=f"{path} (variant {spec.name})")


def plan_run(spec: RunSpec, out_dir: Path,
             progress: Callable[[float], None] | None = None) -> RunOutcome:
    """Plan one run into ``out_dir/<name>``; errors become an ``"error"`` outcome."""
    folder = out_dir / spec.name
    clock = time.perf_counter()
    try:
        sc = load_run(spec)
        problem = sc.build()
        result = get_planner(sc.method)().plan(problem, progress=progress)
        write_plan(folder, analyse(result, problem), problem, sc)
        status, message = result.status.value, result.message
    except MmplanError as exc:
        status, message = "error", str(exc)
    except Exception as exc:  # a bug in one planner must not stop the reproduction
        first = str(exc).splitlines()[0] if str(exc) else ""
        status, message = "error", f"internal error: {type(exc).__name__}: {first}"
    return RunOutcome(spec, folder, status, message, time.perf_counter() - clock)


def add_report(run: RunOutcome) -> RunOutcome:
    """Write the run's report.html (the report module is imported here, on demand)."""
    if not run.planned:
        return run
    try:
        from mmplan.report import write_report

        path = write_report(run.directory)
    except (MmplanError, ImportError) as exc:
        return _with_report(run, None, str(exc))
    except Exception as exc:  # a report bug must not lose the other results
        return _with_report(run, None, f"internal error: {type(exc).__name__}: {exc}")
    return _with_report(run, path, None)


def _with_report(run: RunOutcome, path: Path | None, error: str | None) -> RunOutcome:
    return RunOutcome(run.spec, run.directory, run.status, run.message, run.wall_time_s,
                      path, error)


def reproduce(out_dir: str | Path, only: Sequence[str] = (), report: bool = True,
              progress: ProgressFn | None = None) -> Reproduction:
    """Plan the paper scenarios into ``out_dir`` and write the comparison tables.

    Args:
        out_dir: Output folder (created; existing run folders are replaced).
        only: Scenario names to run (default all); variants follow their base scenario.
        report: Also write each run's report.html.
        progress: Called with (run name, progress in runs, number of runs).

    Returns:
        The runs, the evaluated reference rows and the paths of the tables.

    Raises:
        InputError: unknown name in ``only`` or an unusable ``out_dir``.
    """
    from mmplan.reproduce.table import write_tables

    specs = run_specs(only)
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError("--out", f"{out} exists and is not a directory")
    out.mkdir(parents=True, exist_ok=True)
    clock = time.perf_counter()
    runs: list[RunOutcome] = []
    share = 0.7 if report else 1.0  # of a run's progress step: planning, then the report
    for i, spec in enumerate(specs):
        def step(fraction: float, i: int = i, name: str = spec.name) -> None:
            if progress is not None:
                progress(name, i + share * min(max(float(fraction), 0.0), 1.0), len(specs))

        step(0.0)
        run = plan_run(spec, out, step)
        if report:
            if progress is not None:
                progress(f"{spec.name} (report)", i + share, len(specs))
            run = add_report(run)
        runs.append(run)
        if progress is not None:
            progress(spec.name, i + 1.0, len(specs))
    rows = tuple(evaluate(ref, _files(runs)) for ref in _selected(REFERENCES, specs))
    wall = time.perf_counter() - clock
    md, html = write_tables(out, tuple(runs), rows, wall)
    return Reproduction(out, tuple(runs), rows, md, html, wall)


def _selected(refs: Sequence[Reference], specs: Sequence[RunSpec]) -> list[Reference]:
    names = {s.name for s in specs}
    return [r for r in refs if all(run in names for run in r.measure.runs)]


def _files(runs: Sequence[RunOutcome]) -> dict[str, RunOutcome]:
    return {r.spec.name: r for r in runs}

