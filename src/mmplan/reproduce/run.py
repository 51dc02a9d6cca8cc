"""``mmplan reproduce``: plan every built-in paper scenario and compare with the papers.

Runs the scenarios of :data:`mmplan.reproduce.published.SCENARIOS` (and the variants the references
compare against), writes each plan to ``OUT/<name>/`` (:func:`mmplan.write_plan`) with its
report, then evaluates every :data:`~mmplan.reproduce.published.REFERENCES` row from the written
files
and writes ``OUT/REPRODUCTION.md`` and ``OUT/reproduction.html``
(:mod:`mmplan.reproduce.table`). A scenario that fails is recorded with its status, never raised.
The runs are independent: by default several go at a time, each in a forked worker process
(:mod:`mmplan.reproduce.workers`; one per idle CPU, at most :data:`MAX_JOBS`), each planning and
then drawing its own report (the plotting stack is imported once per worker).
No CLI or plotting imports: progress goes to a callback; the report module (optional extra)
is imported only when reports are asked for.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from mmplan.analysis import analyse
from mmplan.errors import InputError, MmplanError
from mmplan.io.plan_folder import write_plan
from mmplan.planners import get_planner
from mmplan.reproduce.evaluate import Evaluated, evaluate, with_floor_note
from mmplan.reproduce.published import REFERENCES, SCENARIOS, VARIANTS, Reference
from mmplan.reproduce.runs import RunOutcome, RunSpec
from mmplan.reproduce.workers import Report, can_fork, in_workers
from mmplan.scenario import safe_yaml
from mmplan.scenario.loader import Scenario, builtin_scenarios, load_scenario

#: progress(run name, runs finished + fraction of the current run, number of runs)
ProgressFn = Callable[[str, float, int], None]

#: Share of a run's progress step that planning takes (the rest: its report).
PLAN_SHARE = 0.7
#: Most runs at a time by default (each worker holds the planners and the plotting stack).
MAX_JOBS = 4


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
        specs += [RunSpec(v.name, paper, v.base, dict(v.planner), v.note, dict(v.scenario))
                  for v in VARIANTS if v.base == name]
    wanted = [n.strip() for item in only for n in item.split(",") if n.strip()]
    if not wanted:
        return tuple(specs)
    # built-in scenarios without paper numbers run only when named (e.g. wall-segment-limits)
    specs += [RunSpec(name, "") for name in builtin_scenarios() if name not in SCENARIOS]
    known = [s.name for s in specs]
    for name in wanted:
        if name not in known:  # scenarios first, then variants: an error line is cut at 500
            listed = [s.name for s in specs if s.base is None] + \
                [s.name for s in specs if s.base is not None]
            raise InputError("--only", f"unknown scenario {name!r}; choose one of "
                                       f"{', '.join(listed)}")
    return tuple(s for s in specs
                 if s.name in wanted or (s.base is not None and s.base in wanted))


def load_run(spec: RunSpec) -> Scenario:
    """The scenario of a run (a variant: the base file with its planner settings and its
    top-level ``scenario`` keys replaced)."""
    if spec.base is None:
        return load_scenario(spec.name)
    path = builtin_scenarios()[spec.base]
    data = safe_yaml.load(path.read_text(encoding="utf-8"))
    data["name"] = spec.name
    data["planner"] = {**data["planner"], **(spec.planner or {})}
    data.update(spec.scenario or {})
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


def add_report(run: RunOutcome, parallel: bool = True) -> RunOutcome:
    """Write the run's report.html (the report module is imported here, on demand);
    ``parallel``: draw half of it in a forked child (off when runs go in parallel)."""
    if not run.planned:
        return run
    try:
        from mmplan.report import write_report

        path = write_report(run.directory, parallel=parallel)
    except (MmplanError, ImportError) as exc:
        return _with_report(run, None, str(exc))
    except Exception as exc:  # a report bug must not lose the other results
        return _with_report(run, None, f"internal error: {type(exc).__name__}: {exc}")
    return _with_report(run, path, None)


def _with_report(run: RunOutcome, path: Path | None, error: str | None) -> RunOutcome:
    return RunOutcome(run.spec, run.directory, run.status, run.message, run.wall_time_s,
                      path, error)


def default_jobs() -> int:
    """Runs at a time by default: one per idle CPU (the CPUs minus the 1-minute load
    average, like ``make -l``), at least 1, at most :data:`MAX_JOBS`; 1 where processes
    cannot be forked (the runs then go one after the other in this process). Measured on 2
    cores, the 12 paper runs with reports: nearly idle 16 s with two workers, 22 s with one;
    at load 4-5 (other jobs) 52 s with two, 48 s with one (a second worker only adds its
    own imports)."""
    if not can_fork():
        return 1
    try:
        busy = os.getloadavg()[0]
    except OSError:  # pragma: no cover - no load average on this system
        busy = 0.0
    idle = (os.cpu_count() or 1) - round(busy)
    return max(1, min(MAX_JOBS, idle))


def reproduce(out_dir: str | Path, only: Sequence[str] = (), report: bool = True,
              progress: ProgressFn | None = None, jobs: int | None = None,
              finished: Callable[[RunOutcome], None] | None = None) -> Reproduction:
    """Plan the paper scenarios into ``out_dir`` and write the comparison tables.

    Args:
        out_dir: Output folder (created; existing run folders are replaced).
        only: Scenario names to run (default all); variants follow their base scenario.
        report: Also write each run's report.html.
        progress: Called with (run name, progress in runs, number of runs).
        jobs: Runs at a time, each in a forked worker process (default
            :func:`default_jobs`); 1 runs them one after the other in this process.
        finished: Called with each run's outcome as it finishes (in finishing order).

    Returns:
        The runs (in :func:`run_specs` order), the evaluated reference rows and the paths of
        the tables.

    Raises:
        InputError: unknown name in ``only``, ``jobs`` < 1 or an unusable ``out_dir``.
    """
    from mmplan.reproduce.table import write_tables

    specs = run_specs(only)
    jobs = default_jobs() if jobs is None else jobs
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise InputError("--jobs", f"must be a whole number >= 1, got {jobs!r}")
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError("--out", f"{out} exists and is not a directory")
    out.mkdir(parents=True, exist_ok=True)
    clock = time.perf_counter()
    tracker = _Tracker(specs, progress, finished)
    if jobs == 1 or len(specs) == 1 or not can_fork():
        for i, spec in enumerate(specs):
            tracker.done(i, _plan_and_report(spec, out, report, True, tracker.reporter(i)))
    else:
        calls = [(spec, out, report, False) for spec in specs]
        in_workers(_plan_and_report, calls, min(jobs, len(specs)), tracker.update,
                   lambda i, error: tracker.done(i, _failed(specs[i], out, error)),
                   tracker.done)
    runs = tuple(tracker.runs[i] for i in range(len(specs)))
    rows = tuple(with_floor_note(evaluate(ref, _files(runs)), _files(runs))
                 for ref in _selected(REFERENCES, specs))
    wall = time.perf_counter() - clock
    md, html = write_tables(out, runs, rows, wall)
    return Reproduction(out, runs, rows, md, html, wall)


class _Tracker:
    """Progress over all runs (each run's fraction summed) and the finished outcomes."""

    def __init__(self, specs: Sequence[RunSpec], progress: ProgressFn | None,
                 finished: Callable[[RunOutcome], None] | None) -> None:
        self.specs, self.progress, self.finished = specs, progress, finished
        self.fractions = [0.0] * len(specs)
        self.runs: dict[int, RunOutcome] = {}

    def update(self, i: int, label: str, fraction: float) -> None:
        self.fractions[i] = min(max(float(fraction), 0.0), 1.0)
        if self.progress is not None:
            self.progress(f"{self.specs[i].name}{label}", sum(self.fractions), len(self.specs))

    def reporter(self, i: int) -> Report:
        return lambda label, fraction: self.update(i, label, fraction)

    def done(self, i: int, run: RunOutcome) -> None:
        self.runs[i] = run
        self.update(i, "", 1.0)
        if self.finished is not None:
            self.finished(run)


def _failed(spec: RunSpec, out: Path, error: str) -> RunOutcome:
    """A run whose worker process died (killed, crashed)."""
    return RunOutcome(spec, out / spec.name, "error", f"internal error: {error}", 0.0)


def _plan_and_report(spec: RunSpec, out: Path, report: bool, parallel: bool,
                     note: Report) -> RunOutcome:
    share = PLAN_SHARE if report else 1.0
    note("", 0.0)
    run = plan_run(spec, out, lambda fraction: note("", share * float(fraction)))
    if report:
        note(" (report)", share)
        run = add_report(run, parallel=parallel)
    return run


def _selected(refs: Sequence[Reference], specs: Sequence[RunSpec]) -> list[Reference]:
    names = {s.name for s in specs}
    return [r for r in refs if all(run in names for run in r.measure.runs)]


def _files(runs: Sequence[RunOutcome]) -> dict[str, RunOutcome]:
    return {r.spec.name: r for r in runs}

