"""``mmplan report`` as a user meets it: wall time of the command on the paper scenario.

Plans ``youbot3r-obstacles-torque`` once into a temporary folder, then runs, each in a fresh
process (warm disk cache), all in the same run of this script:

* baseline: ``mmplan --help`` (interpreter + the CLI, what every command pays);
* ``mmplan report DIR``: the first run on the new plan folder (no figures/ yet), then the
  best and median of ``--repeat`` runs;
* with ``--against SRC`` (another source tree of mmplan, e.g. the last commit's:
  ``git archive HEAD src | tar -x -C /tmp/base``, then ``--against /tmp/base/src``): that
  tree's ``mmplan report`` run alternately with this one's (ABBA order, so a load that
  changes during the run weighs on both alike), with the median of the paired ratios;
* the parts of a report drawn in one process one after the other (``parallel=False``):
  import of the plotting stack, reading the plan, deriving, the 3D view, the figures (those
  of the plan's files alone, the spatial ones with the clearance, the other time series), the
  check and the page (where the time goes; the command overlaps them in three processes).

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
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SCENARIO = "youbot3r-obstacles-torque"
CLI = [sys.executable, "-m", "mmplan.cli"]

PARTS = """
import time, json
t = [time.perf_counter()]
def mark(): t.append(time.perf_counter())
import mmplan.report
from mmplan.report import build, check_failures
mark()
from mmplan.report.plan_data import read_plan_dir
from mmplan.report.context import build_context
plan = read_plan_dir(DIR); mark()
ctx = build_context(plan, max_samples=1000); mark()
from mmplan.report.scene3d import scene_commands
from mmplan.report.html import page, viewer_block
viewer = viewer_block(scene_commands(ctx, 1000)); mark()
from mmplan.report.file_figures import file_figures
figures = file_figures(plan); mark()
figures += build.first_half(ctx); mark()
figures += build.second_half(ctx); mark()
check_failures(DIR); mark()
from mmplan.report.overview import overview
page(plan.summary, plan.scenario, overview(ctx), build.order(figures), viewer); mark()
names = ["import (matplotlib, report)", "read the plan", "derive (model, FK, clearance)",
         "3D view (meshcat)", "figures of the files", "spatial figures, clearance",
         "other time series", "check", "page"]
print(json.dumps(dict(zip(names, [b - a for a, b in zip(t, t[1:])]))))
print(len(figures))
"""


def wall(command: list[str], src: str | None = None) -> float:
    """Wall time [s] of one run of ``command`` (output discarded, must succeed); ``src``: the
    mmplan source tree to run (PYTHONPATH), None: the installed one."""
    env = None if src is None else {**os.environ, "PYTHONPATH": src}
    start = time.perf_counter()
    subprocess.run(command, check=True, capture_output=True, env=env)
    return time.perf_counter() - start


def best_and_median(command: list[str], repeat: int) -> tuple[float, float]:
    times = [wall(command) for _ in range(repeat)]
    return min(times), statistics.median(times)


def alternating(command: list[str], src: str, repeat: int) -> tuple[list[float], list[float]]:
    """Wall times of ``command`` run from ``src`` and from this tree, ``repeat`` pairs in
    ABBA order."""
    theirs: list[float] = []
    ours: list[float] = []
    for i in range(repeat):
        if i % 2 == 0:
            theirs.append(wall(command, src))
            ours.append(wall(command))
        else:
            ours.append(wall(command))
            theirs.append(wall(command, src))
    return theirs, ours


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
        spinners = busy(args.load)
        try:
            first = wall(report)
            base, base_med = best_and_median([*CLI, "--help"], args.repeat)
            best, med = best_and_median(report, args.repeat)
            theirs, ours = alternating(report, args.against, args.repeat) if args.against \
                else ([], [])
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
    if theirs:
        ratios = [a / b for a, b in zip(ours, theirs, strict=True)]
        print(f"alternating with {args.against}:")
        print(f"{'  mmplan report (that tree)':34s} {min(theirs):9.3f} "
              f"{statistics.median(theirs):11.3f} {min(theirs) / base:11.2f}")
        print(f"{'  mmplan report (this tree)':34s} {min(ours):9.3f} "
              f"{statistics.median(ours):11.3f} {min(ours) / base:11.2f}")
        print(f"  this / that, median of the pairs: {statistics.median(ratios):.3f}")
    print(f"where the time goes (one process, one after the other; {count} figures):")
    for name, seconds in json.loads(timings).items():
        print(f"  {name:32s} {seconds:9.3f}")


if __name__ == "__main__":
    main()
