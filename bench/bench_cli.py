"""``mmplan plan`` as a user meets it: process wall time vs the planner's compute time vs
the import time, in one run of this script (warm disk and compile caches).

Cases, each in fresh processes, best and median of ``--repeat`` runs:

* ``mmplan plan SCENARIO --out DIR -q`` (default ``youbot3r-obstacles-torque``): the wall time
  of the process, and the planner's compute time it wrote to summary.json;
* imports: a fresh interpreter importing every mmplan module that command loads (listed by
  a probe run; their dependencies come along), interpreter start included;
* ``python -c pass``: the interpreter alone.

Then one process doing what the command does, step by step (where the rest goes: scenario,
planning, the plan's studies, check and write). Target (issue: speed as a user meets it):
wall <= compute + imports, i.e. ``wall / (compute + imports) <= 1``. Run:
``python bench/bench_cli.py [--repeat 7] [--scenario NAME] [--load N]``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

PROBE = """
import sys
from mmplan.cli.main import main
try:
    main([{args}])
except SystemExit:
    pass
print(' '.join(sorted(m for m in sys.modules if m.startswith('mmplan'))))
"""

STEPS = """
import json, time
t = [time.perf_counter()]
def mark(): t.append(time.perf_counter())
import mmplan
from mmplan.analysis import analyse
sc = mmplan.load_scenario({scenario!r}); mark()
problem = sc.build(); planner = mmplan.get_planner(sc.method)(); mark()
result = planner.plan(problem); mark()
result = analyse(result, problem); mark()
mmplan.write_plan({out!r}, result, problem, sc); mark()
names = ["load the scenario", "build the problem, load the planner", "plan",
         "study the plan (vibration)", "check and write"]
print(json.dumps(dict(zip(names, [b - a for a, b in zip(t, t[1:])]))))
"""


def wall(command: list[str]) -> float:
    start = time.perf_counter()
    subprocess.run(command, check=True, capture_output=True)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--scenario", default="youbot3r-obstacles-torque")
    parser.add_argument("--load", type=int, default=0, help="busy processes meanwhile")
    args = parser.parse_args()
    py = sys.executable
    with tempfile.TemporaryDirectory() as tmp:
        out = str(Path(tmp) / "plan")
        plan = [py, "-m", "mmplan.cli", "plan", args.scenario, "--out", out, "-q"]
        subprocess.run(plan, check=False, capture_output=True)  # warm the caches
        cli_args = ", ".join(repr(a) for a in ["plan", args.scenario, "--out", out, "-q"])
        modules = subprocess.run([py, "-c", PROBE.format(args=cli_args)], check=True,
                                 capture_output=True, text=True).stdout.split()
        imports = [py, "-c", "import " + ", ".join(modules)]
        spinners = [subprocess.Popen([py, "-c", "while True: pass"]) for _ in range(args.load)]
        try:
            walls, computes, loads, bare = [], [], [], []
            for _ in range(args.repeat):  # interleaved: the same conditions for each case
                start = time.perf_counter()
                subprocess.run(plan, check=False, capture_output=True)
                walls.append(time.perf_counter() - start)
                summary = json.loads((Path(out) / "summary.json").read_text())
                computes.append(float(summary["compute_time_s"]))
                loads.append(wall(imports))
                bare.append(wall([py, "-c", "pass"]))
            steps = json.loads(subprocess.run(
                [py, "-c", STEPS.format(scenario=args.scenario, out=out + "-steps")],
                check=True, capture_output=True, text=True).stdout)
        finally:
            for p in spinners:
                p.kill()
                p.wait()
    med = statistics.median
    w, c, i = med(walls), med(computes), med(loads)
    print(f"mmplan plan {args.scenario} -q: {args.repeat} runs each, {args.load} busy "
          f"processes; {len(modules)} mmplan modules imported")
    print(f"{'case':44s} {'best [s]':>9s} {'median [s]':>11s}")
    for name, values in (("process wall time", walls), ("planner compute time", computes),
                         ("imports (fresh interpreter)", loads), ("python -c pass", bare)):
        print(f"{name:44s} {min(values):9.3f} {med(values):11.3f}")
    print("ratios (medians):")
    print(f"  wall / compute                       {w / c:7.2f}")
    print(f"  wall / (compute + imports)           {w / (c + i):7.2f}   (target <= 1)")
    print(f"  rest = wall - compute - imports      {w - c - i:7.3f} s")
    print("one process, step by step (imports of each step included in it):")
    for name, seconds in steps.items():
        print(f"  {name:36s} {seconds:7.3f} s")


if __name__ == "__main__":
    main()
