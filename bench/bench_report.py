"""``mmplan report`` as a user meets it: wall time of the command on the paper scenario.

Plans ``youbot3r-obstacles-torque`` once into a temporary folder, then runs, each in a fresh
process (warm disk cache), all in the same run of this script:

* baseline: ``mmplan --help`` (interpreter + the CLI, what every command pays);
* ``mmplan report DIR``: the first run on the new plan folder (no figures/ yet), then the
  best and median of ``--repeat`` runs;
* with ``--against SRC`` (another source tree of mmplan, e.g. the last commit's:
  ``git archive HEAD src | tar -x -C /tmp/base``, then ``--against /tmp/base/src``): that
  tree's ``mmplan report`` run alternately with this one's (ABBA order, so a load that
  changes during the run weighs on both alike), with the median of the paired ratios of the
  wall time and of the CPU time of all its processes (on a loaded machine the wall time
  follows the CPU time: no core is free for the work the command overlaps); the same for
  the first report of a plan (each run on its own copy of the new plan folder);
* the parts of a report drawn in one process one after the other (``parallel=False``):
  import of the plotting stack, import of the models, reading the plan, deriving (with what
  the figures need of the models), the 3D view, the figures (those of the plan's files alone,
  the spatial ones with the clearance, the other time series), the check and the page (where
  the time goes; the command overlaps them in four processes, see mmplan.report.build).

The machine's load average (1 min, /proc/loadavg) is printed before and after: the numbers
are only comparable between runs under a similar load. ``--load N`` keeps N busy processes
running meanwhile (a loaded machine; 2 on two cores leaves the report no core of its own).
Target (issue: speed as a user meets it): the report under 2 s. Run:
``python bench/bench_report.py [--repeat 5] [--load 2] [--against /tmp/base/src]``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

SCENARIO = "youbot3r-obstacles-torque"
CLI = [sys.executable, "-m", "mmplan.cli"]
#: (wall, CPU) times [s] of runs of that tree and of this tree.
Runs = tuple[list[tuple[float, float]], list[tuple[float, float]]]

PARTS = """
import time, json
t = [time.perf_counter()]
def mark(): t.append(time.perf_counter())
import mmplan.report
from mmplan.report import build, check_failures
import mmplan.report.figures_method, mmplan.report.figures, mmplan.report.figures_space
mark()
import mmplan.report.context, mmplan.report.overview, mmplan.verify.check
mark()
from mmplan.report.plan_data import read_plan_dir
from mmplan.report.context import build_context
from mmplan.report.figure_data import figure_data
plan = read_plan_dir(DIR); mark()
ctx = build_context(plan, max_samples=1000); data = figure_data(ctx); mark()
from mmplan.report.scene3d import scene_commands
from mmplan.report.html import page, viewer_block
viewer = viewer_block(scene_commands(ctx, 1000)); mark()
from mmplan.report.file_figures import file_figures
figures = file_figures(plan); mark()
figures += build.first_half(data); mark()
figures += build.second_half(data); mark()
check_failures(DIR); mark()
from mmplan.report.overview import overview
page(plan.summary, plan.scenario, overview(ctx), build.order(figures), viewer); mark()
names = ["import (matplotlib, figures)", "import (models, check)", "read the plan",
         "derive (model, FK, clearance)",
         "3D view (meshcat)", "figures of the files", "spatial figures, clearance",
         "other time series", "check", "page"]
print(json.dumps(dict(zip(names, [b - a for a, b in zip(t, t[1:])]))))
print(len(figures))
"""


def wall(command: list[str], src: str | None = None) -> float:
    """Wall time [s] of one run of ``command`` (output discarded, must succeed); ``src``: the
    mmplan source tree to run (PYTHONPATH), None: the installed one."""
    return timed(command, src)[0]


def timed(command: list[str], src: str | None = None) -> tuple[float, float]:
    """Wall time and CPU time (user + system, with the child processes it waited for) [s] of
    one run of ``command``, as :func:`wall`."""
    env = None if src is None else {**os.environ, "PYTHONPATH": src}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(command, check=True, capture_output=True, env=env)
    seconds = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return seconds, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def best_and_median(command: list[str], repeat: int) -> tuple[float, float]:
    times = [wall(command) for _ in range(repeat)]
    return min(times), statistics.median(times)


def alternating(command: Callable[[int, str], list[str]], src: str, repeat: int) -> Runs:
    """(wall, CPU) times of ``command(i, tree)`` (run i of tree ``"that"`` or ``"this"``) run
    from ``src`` and from this tree, ``repeat`` pairs in ABBA order."""
    theirs: list[tuple[float, float]] = []
    ours: list[tuple[float, float]] = []
    for i in range(repeat):
        if i % 2 == 0:
            theirs.append(timed(command(i, "that"), src))
            ours.append(timed(command(i, "this")))
        else:
            ours.append(timed(command(i, "this")))
            theirs.append(timed(command(i, "that"), src))
    return theirs, ours


def compared(label: str, theirs: list[tuple[float, float]], ours: list[tuple[float, float]],
             base: float) -> None:
    """Best and median wall time, median CPU time of both trees; the medians of the paired
    ratios."""
    for name, runs in (("that", theirs), ("this", ours)):
        walls = [w for w, _ in runs]
        cpu = statistics.median(c for _, c in runs)
        print(f"{f'  {label} ({name} tree)':34s} {min(walls):9.3f} "
              f"{statistics.median(walls):11.3f} {min(walls) / base:11.2f}"
              f"   CPU median {cpu:.3f} s")
    walls, cpus = ([a[i] / b[i] for a, b in zip(ours, theirs, strict=True)] for i in (0, 1))
    print(f"  this / that, median of the pairs: wall {statistics.median(walls):.3f}, "
          f"CPU (all processes) {statistics.median(cpus):.3f}")


def load_average() -> str:
    """The 1-minute load average, or ``?`` where /proc/loadavg is missing."""
    try:
        return Path("/proc/loadavg").read_text().split()[0]
    except OSError:
        return "?"


def busy(n: int) -> list[subprocess.Popen[bytes]]:
    """``n`` processes spinning a core each (killed by the caller)."""
    return [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(n)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--load", type=int, default=0, help="busy processes meanwhile")
    parser.add_argument("--against", metavar="SRC", help="another mmplan source tree")
    args = parser.parse_args()
    before = load_average()
    with tempfile.TemporaryDirectory() as tmp:
        plan_dir = Path(tmp) / "plan"
        subprocess.run([*CLI, "plan", SCENARIO, "--out", str(plan_dir), "-q"], check=True)
        report = [*CLI, "report", str(plan_dir)]

        def fresh(i: int, tree: str) -> list[str]:  # a copy of the plan never reported
            copy = Path(tmp) / f"fresh-{tree}-{i}"
            shutil.copytree(plan_dir, copy)
            return [*CLI, "report", str(copy)]

        spinners = busy(args.load)
        try:
            first = wall(report)
            base, base_med = best_and_median([*CLI, "--help"], args.repeat)
            best, med = best_and_median(report, args.repeat)
            pairs: Runs = ([], [])
            firsts: Runs = ([], [])
            if args.against:
                pairs = alternating(lambda i, tree: report, args.against, args.repeat)
                firsts = alternating(fresh, args.against, args.repeat)
            parts = subprocess.run([sys.executable, "-c", f"DIR = {str(plan_dir)!r}\n" + PARTS],
                                   check=True, capture_output=True, text=True).stdout
        finally:
            for p in spinners:
                p.kill()
                p.wait()
    after = load_average()
    timings, count = parts.splitlines()

    print(f"mmplan report {SCENARIO}, {args.repeat} runs, {args.load} busy processes, "
          f"load average (1 min) {before} before, {after} after")
    print(f"{'case':34s} {'best [s]':>9s} {'median [s]':>11s} {'/ baseline':>11s}")
    print(f"{'baseline: mmplan --help':34s} {base:9.3f} {base_med:11.3f} {1.0:11.2f}")
    print(f"{'mmplan report: first run':34s} {first:9.3f} {'':11s} {first / base:11.2f}")
    print(f"{'mmplan report':34s} {best:9.3f} {med:11.3f} {best / base:11.2f}")
    if args.against:
        print(f"alternating with {args.against}:")
        compared("mmplan report", *pairs, base)
        compared("first report", *firsts, base)
    print(f"where the time goes (one process, one after the other; {count} figures):")
    for name, seconds in json.loads(timings).items():
        print(f"  {name:32s} {seconds:9.3f}")


if __name__ == "__main__":
    main()
