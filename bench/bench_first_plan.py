"""``mmplan plan`` motion / compute (warm cache) and the first compile of a robot model, each as
a ratio against a baseline measured in the same run.

* First compile: ``mmplan plan SCENARIO`` with an empty ``MMPLAN_CACHE`` (generator and
  time-scaling libraries built), its compute time; baseline: the same command warm.
* Warm CLI: ``--repeat`` fresh processes on the filled cache; motion / compute, with the
  motion the plan's last sample time. Baseline: the same plan repeated inside one process
  (``planner.plan`` a second time: generator loaded, every per-process cost paid), so
  ``CLI compute / in-process compute`` is what a process pays on top of planning.

Targets (issue: speed as a user meets it): motion / compute >= 1000 with the default settings;
first compile of youbot-3r < 5 s. Run: ``python bench/bench_first_plan.py [--repeat 5]
[--scenario NAME] [--load N] [--baseline-src DIR]``; with ``--baseline-src`` (e.g. the
``src`` of ``git archive HEAD src | tar -x -C DIR``) the same runs of that code version are
interleaved with these (ABBA) and the ratios printed, for the warm CLI also the median of the
paired ratios (this machine's speed drifts between minutes: pairs compare like with like).
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

IN_PROCESS = """
import json, sys
import mmplan
sc = mmplan.load_scenario({scenario!r})
problem = sc.build(); planner = mmplan.get_planner(sc.method)()
times = [planner.plan(problem).compute_time_s for _ in range({repeat})]
print(json.dumps(times))
"""


def _env(cache: str, src: str | None) -> dict[str, str]:
    env = dict(os.environ, MMPLAN_CACHE=cache)
    if src is not None:  # another copy of the code, e.g. ``git archive HEAD src | tar -x``
        env["PYTHONPATH"] = os.pathsep.join([src, env.get("PYTHONPATH", "")])
    return env


def cli_plan(scenario: str, out: Path, cache: str, src: str | None) -> tuple[float, float]:
    """(compute time, motion duration) of one ``mmplan plan`` process."""
    subprocess.run([sys.executable, "-m", "mmplan.cli", "plan", scenario, "--out", str(out),
                    "-q"], check=True, capture_output=True, env=_env(cache, src))  # fmt: skip
    summary = json.loads((out / "summary.json").read_text())
    with (out / "trajectory.csv").open() as f:
        rows = list(csv.reader(f))
    return float(summary["compute_time_s"]), float(rows[-1][0])


def in_process(scenario: str, repeat: int, cache: str, src: str | None) -> list[float]:
    """Compute times of ``repeat`` plans in one process after a first one."""
    code = IN_PROCESS.format(scenario=scenario, repeat=repeat + 1)
    out = subprocess.run([sys.executable, "-c", code], check=True, env=_env(cache, src),
                         capture_output=True, text=True).stdout  # fmt: skip
    return list(json.loads(out))[1:]


def measure(scenario: str, repeat: int, tmp: Path, codes: dict[str, str | None]) -> dict:
    """Cold, warm and in-process times of each code version, runs interleaved."""
    res: dict[str, dict] = {k: {"warm": [], "steady": []} for k in codes}
    for k, src in codes.items():
        res[k]["cold"], res[k]["motion"] = cli_plan(scenario, tmp / f"{k}c", str(tmp / k), src)
    for i in range(repeat):  # ABBA order: a load that changes weighs on both alike
        for k, src in (list(codes.items()) if i % 2 == 0 else list(codes.items())[::-1]):
            res[k]["warm"].append(cli_plan(scenario, tmp / f"{k}{i}", str(tmp / k), src)[0])
    for k, src in codes.items():
        res[k]["steady"] = in_process(scenario, repeat, str(tmp / k), src)
    return res


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="youbot3r-obstacles-torque")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--load", type=int, default=0, help="busy processes meanwhile")
    parser.add_argument(
        "--baseline-src", default=None, help="src folder of a baseline code version (interleaved)"
    )
    args = parser.parse_args()
    codes: dict[str, str | None] = {"this": None}
    if args.baseline_src:
        codes["baseline"] = args.baseline_src
    spinners = [subprocess.Popen([sys.executable, "-c", "while True: pass"])
                for _ in range(args.load)]  # fmt: skip
    try:
        with tempfile.TemporaryDirectory() as tmp:
            res = measure(args.scenario, args.repeat, Path(tmp), codes)
    finally:
        for p in spinners:
            p.kill()
    print(f"{args.scenario}: {args.repeat} runs, {args.load} busy processes, "
          f"{os.cpu_count()} cores")  # fmt: skip
    for k, r in res.items():
        w, s, cold, motion = (statistics.median(r["warm"]), statistics.median(r["steady"]),
                              r["cold"], r["motion"])  # fmt: skip
        r["w"] = w
        print(f"[{k}] motion {motion:.3f} s")
        print(f"  first plan, empty cache (compiles): {cold:7.3f} s   = {cold / w:6.1f} x warm")
        print(f"  CLI warm compute (median, best):    {w:7.3f} s ({min(r['warm']):.3f} s)")
        print(f"  in-process repeat (median):         {s:7.3f} s   CLI / in-process = {w / s:.2f}")
        print(f"  motion / compute: CLI {motion / w:6.0f} (best {motion / min(r['warm']):.0f}), "
              f"in-process {motion / s:6.0f}   target >= 1000")  # fmt: skip
        print(f"  first compile < 5 s: {'met' if cold < 5.0 else 'not met'} ({cold:.2f} s)")
    if "baseline" in res:
        b, t = res["baseline"], res["this"]
        print(f"this / baseline: CLI warm compute {t['w'] / b['w']:.2f}, first plan "
              f"{t['cold'] / b['cold']:.2f}, motion {t['motion'] / b['motion']:.6f}")  # fmt: skip
        pairs = [x / y for x, y in zip(t["warm"], b["warm"], strict=True)]
        print(f"  CLI warm compute, median of the {len(pairs)} paired ratios (run i of each): "
              f"{statistics.median(pairs):.3f}")  # fmt: skip


if __name__ == "__main__":
    main()
