"""``mmplan plan`` as a user meets it: process wall time vs the planner's compute time vs
the import time, in one run of this script (warm disk and compile caches).

Cases, each in fresh processes, best and median of ``--repeat`` runs:

* ``mmplan plan SCENARIO --out DIR -q`` (default ``youbot3r-obstacles-torque``): the wall time
  and the CPU time (user + system, less disturbed by a busy machine) of the process, and the
  planner's compute time it wrote to summary.json;
* imports: a fresh interpreter importing every mmplan module that command loads (listed by
  a probe run; their dependencies come along), interpreter start included;
* ``python -c pass``: the interpreter alone;
* with ``--baseline SRC``: the same command run from another source tree (e.g. the last
  commit's: ``git archive HEAD src | tar -x -C /tmp/base``, then ``--baseline /tmp/base/src``),
  alternating with this tree's runs.

Then one process doing what the command does, step by step (where the rest goes: scenario,
planning, the plan's studies, check and write). Target (issue: speed as a user meets it):
wall <= compute + imports, i.e. ``wall / (compute + imports) <= 1``. Run:
``python bench/bench_cli.py [--repeat 7] [--scenario NAME] [--load N] [--baseline SRC]``.
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
from mmplan.verify.native import compiled_checks
mark()
sc = mmplan.load_scenario({scenario!r}); mark()
with compiled_checks(sc.robot, build=True):  # as the command: the checker's functions in C
    problem = sc.build(); planner = mmplan.get_planner(sc.method)(); mark()
    result = planner.plan(problem); mark()
    result = analyse(result, problem); mark()
    mmplan.write_plan({out!r}, result, problem, sc); mark()
names = ["import mmplan, analysis, native", "load the scenario",
         "build the problem, load the planner", "plan", "study the plan (vibration)",
         "check and write"]
print(json.dumps(dict(zip(names, [b - a for a, b in zip(t, t[1:])]))))
"""


def wall(command: list[str]) -> float:
    return timed(command)[0]


def timed(command: list[str], env: dict[str, str] | None = None) -> tuple[float, float]:
    """Wall time and CPU time (user + system) [s] of one run of ``command``."""
    start = time.perf_counter()
    proc = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            env=env)
    usage = os.wait4(proc.pid, 0)[2]
    proc.returncode = 0  # reaped by wait4
    return time.perf_counter() - start, usage.ru_utime + usage.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--scenario", default="youbot3r-obstacles-torque")
    parser.add_argument("--load", type=int, default=0, help="busy processes meanwhile")
    parser.add_argument("--baseline", metavar="SRC", help="another source tree to compare")
    args = parser.parse_args()
    py = sys.executable
    base_env = None
    if args.baseline:
        base_env = dict(os.environ, PYTHONPATH=str(Path(args.baseline).resolve()))
    with tempfile.TemporaryDirectory() as tmp:
        out = str(Path(tmp) / "plan")
        plan = [py, "-m", "mmplan.cli", "plan", args.scenario, "--out", out, "-q"]
        subprocess.run(plan, check=False, capture_output=True)  # warm the caches
        if base_env is not None:
            subprocess.run(plan, check=False, capture_output=True, env=base_env)
        cli_args = ", ".join(repr(a) for a in ["plan", args.scenario, "--out", out, "-q"])
        modules = subprocess.run([py, "-c", PROBE.format(args=cli_args)], check=True,
                                 capture_output=True, text=True).stdout.split()
        imports = [py, "-c", "import " + ", ".join(modules)]
        spinners = [subprocess.Popen([py, "-c", "while True: pass"]) for _ in range(args.load)]
        try:
            walls, cpus, computes, loads, bare = [], [], [], [], []
            base_walls, base_cpus, base_computes = [], [], []
            for _ in range(args.repeat):  # interleaved: the same conditions for each case
                w, c = timed(plan)
                walls.append(w)
                cpus.append(c)
                summary = json.loads((Path(out) / "summary.json").read_text())
                computes.append(float(summary["compute_time_s"]))
                if base_env is not None:
                    w, c = timed(plan, base_env)
                    base_walls.append(w)
                    base_cpus.append(c)
                    summary = json.loads((Path(out) / "summary.json").read_text())
                    base_computes.append(float(summary["compute_time_s"]))
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
          f"processes (load average at the end {os.getloadavg()[0]:.2f}); {len(modules)} mmplan "
          "modules imported")
    print(f"{'case':44s} {'best [s]':>9s} {'median [s]':>11s}")
    cases = [("process wall time", walls), ("process CPU time (user + sys)", cpus),
             ("planner compute time", computes), ("imports (fresh interpreter)", loads),
             ("python -c pass", bare)]
    if base_env is not None:
        cases += [("baseline: process wall time", base_walls),
                  ("baseline: process CPU time (user + sys)", base_cpus),
                  ("baseline: planner compute time", base_computes)]
    for name, values in cases:
        print(f"{name:44s} {min(values):9.3f} {med(values):11.3f}")
    print("ratios (medians):")
    print(f"  wall / compute                       {w / c:7.2f}")
    print(f"  wall / (compute + imports)           {w / (c + i):7.2f}   (target <= 1)")
    print(f"  rest = wall - compute - imports      {w - c - i:7.3f} s")
    if base_env is not None:
        print(f"  baseline wall / this wall            {med(base_walls) / w:7.2f}")
        print(f"  baseline CPU / this CPU              {med(base_cpus) / med(cpus):7.2f}")
    print("one process, step by step (imports of each step included in it):")
    for name, seconds in steps.items():
        print(f"  {name:36s} {seconds:7.3f} s")


if __name__ == "__main__":
    main()
