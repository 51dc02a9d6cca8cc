"""``mmplan report`` as a user meets it: wall time of the command on the paper scenario.

Plans ``youbot3r-obstacles-torque`` once into a temporary folder, then runs, each in a fresh
process (warm disk cache), all in the same run of this script:

* baseline: ``mmplan --help`` (interpreter + the CLI, what every command pays);
* ``mmplan report DIR``: the first run on the new plan folder (no figures/ yet), then the
  best and median of ``--repeat`` runs;
* the parts of a report drawn in one process one after the other (``parallel=False``):
  import of the plotting stack, reading the plan, deriving, the 3D view, the figures, the
  check and the page (where the time goes; the command overlaps some of them).

``--load N`` keeps N busy processes running meanwhile (a loaded machine; 2 on two cores
leaves the report no core of its own). Target (issue: speed as a user meets it): the
report under 2 s. Run: ``python bench/bench_report.py [--repeat 5] [--load 2]``.
"""

from __future__ import annotations

import argparse
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
figures = build.first_half(ctx) + build.second_half(ctx); mark()
check_failures(DIR); mark()
from mmplan.report.overview import overview
page(plan.summary, plan.scenario, overview(ctx), figures, viewer); mark()
names = ["import (matplotlib, report)", "read the plan", "derive (model, FK, clearance)",
         "3D view (meshcat)", f"{len(figures)} figures", "check", "page"]
print(json.dumps(dict(zip(names, [b - a for a, b in zip(t, t[1:])]))))
"""


def wall(command: list[str]) -> float:
    """Wall time [s] of one run of ``command`` (output discarded, must succeed)."""
    start = time.perf_counter()
    subprocess.run(command, check=True, capture_output=True)
    return time.perf_counter() - start


def best_and_median(command: list[str], repeat: int) -> tuple[float, float]:
    times = [wall(command) for _ in range(repeat)]
    return min(times), statistics.median(times)


def busy(n: int) -> list[subprocess.Popen[bytes]]:
    """``n`` processes spinning a core each (killed by the caller)."""
    return [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(n)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--load", type=int, default=0, help="busy processes meanwhile")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        plan_dir = Path(tmp) / "plan"
        subprocess.run([*CLI, "plan", SCENARIO, "--out", str(plan_dir), "-q"], check=True)
        spinners = busy(args.load)
        try:
            first = wall([*CLI, "report", str(plan_dir)])
            base, base_med = best_and_median([*CLI, "--help"], args.repeat)
            best, med = best_and_median([*CLI, "report", str(plan_dir)], args.repeat)
            parts = subprocess.run([sys.executable, "-c", f"DIR = {str(plan_dir)!r}\n" + PARTS],
                                   check=True, capture_output=True, text=True).stdout
        finally:
            for p in spinners:
                p.kill()
                p.wait()
    import json

    print(f"mmplan report {SCENARIO}, {args.repeat} runs, {args.load} busy processes")
    print(f"{'case':34s} {'best [s]':>9s} {'median [s]':>11s} {'/ baseline':>11s}")
    print(f"{'baseline: mmplan --help':34s} {base:9.3f} {base_med:11.3f} {1.0:11.2f}")
    print(f"{'mmplan report: first run':34s} {first:9.3f} {'':11s} {first / base:11.2f}")
    print(f"{'mmplan report':34s} {best:9.3f} {med:11.3f} {best / base:11.2f}")
    print("where the time goes (one process, one after the other):")
    for name, seconds in json.loads(parts).items():
        print(f"  {name:32s} {seconds:9.3f}")


if __name__ == "__main__":
    main()
