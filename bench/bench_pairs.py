"""This tree against another source tree in alternated fresh processes (the machine's speed
drifts between minutes: only pairs run back to back compare like with like).

* ``cli``: ``mmplan plan SCENARIO --out DIR -q`` of each tree (``PYTHONPATH=SRC``), the
  planner's compute time read from ``summary.json``: median and best of each, the median of
  the paired ratios, and motion / compute with the motion the trajectory's last sample time.
* ``process``: a fresh interpreter of each tree builds the scenario, plans once (a process's
  first plan: libraries loaded, first calls paid) and then ``--plans`` more times (median of
  those: a repeated plan).

Both trees need their compiled libraries on disk (run ``mmplan plan SCENARIO`` once with each);
the other tree, e.g. ``git archive HEAD src | tar -x -C /tmp/base``. Run:
``python bench/bench_pairs.py --baseline /tmp/base/src [--pairs 12] [--mode cli|process]
[--scenario NAME] [--plans 25]``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

INPROCESS = """
import json, sys, time
import mmplan
sc = mmplan.load_scenario({scenario!r}); problem = sc.build()
planner = mmplan.get_planner(sc.method)()
t = time.perf_counter(); result = planner.plan(problem); first = time.perf_counter() - t
times = []
for _ in range({plans}):
    t = time.perf_counter(); planner.plan(problem); times.append(time.perf_counter() - t)
times.sort()
print(json.dumps({{"first": first, "repeated": times[len(times) // 2],
                  "motion": float(result.trajectory.t[-1])}}))
"""


def _cli(src: str, scenario: str) -> dict[str, float]:
    out = Path(tempfile.mkdtemp(prefix="mmplan-pairs-"))
    env = dict(os.environ, PYTHONPATH=src)
    subprocess.run([sys.executable, "-m", "mmplan.cli", "plan", scenario, "--out", str(out), "-q"],
                   env=env, check=False)  # fmt: skip
    summary = json.loads((out / "summary.json").read_text())
    last = (out / "trajectory.csv").read_text().rstrip().rsplit("\n", 1)[-1]
    return {"compute": float(summary["compute_time_s"]), "motion": float(last.split(",")[0])}


def _process(src: str, scenario: str, plans: int) -> dict[str, float]:
    env = dict(os.environ, PYTHONPATH=src)
    code = INPROCESS.format(scenario=scenario, plans=plans)
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=True)  # fmt: skip
    return dict(json.loads(run.stdout.strip().splitlines()[-1]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", required=True, help="the other tree's src folder")
    parser.add_argument("--pairs", type=int, default=12)
    parser.add_argument("--mode", choices=["cli", "process"], default="cli")
    parser.add_argument("--scenario", default="youbot3r-obstacles-torque")
    parser.add_argument("--plans", type=int, default=25)
    args = parser.parse_args()
    this = str(Path(__file__).resolve().parents[1] / "src")
    trees = {"this": this, "baseline": args.baseline}
    runs: dict[str, list[dict[str, float]]] = {"this": [], "baseline": []}
    for i in range(args.pairs):
        for name in ("this", "baseline") if i % 2 == 0 else ("baseline", "this"):
            if args.mode == "cli":
                runs[name].append(_cli(trees[name], args.scenario))
            else:
                runs[name].append(_process(trees[name], args.scenario, args.plans))
    keys = ["compute"] if args.mode == "cli" else ["first", "repeated"]
    print(f"{args.scenario}: {args.pairs} alternated pairs ({args.mode}), "
          f"load average at the end {os.getloadavg()[0]:.2f}")  # fmt: skip
    for key in keys:
        for name in ("this", "baseline"):
            values = [r[key] for r in runs[name]]
            print(f"  {key:9s} {name:9s} median {statistics.median(values) * 1e3:7.2f} ms, "
                  f"best {min(values) * 1e3:7.2f} ms")  # fmt: skip
        ratios = [a[key] / b[key] for a, b in zip(runs["this"], runs["baseline"], strict=True)]
        print(f"  {key:9s} paired ratio this / baseline, median {statistics.median(ratios):.3f}")
    motion = runs["this"][0]["motion"]
    typical = statistics.median(r[keys[-1]] for r in runs["this"])
    best = min(r[keys[-1]] for r in runs["this"])
    print(f"  motion {motion:.3f} s (last sample): motion / compute ({keys[-1]}) "
          f"{motion / typical:.0f} median, {motion / best:.0f} best")


if __name__ == "__main__":
    main()
