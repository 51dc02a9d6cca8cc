"""Far obstacles cost nothing: youbot3r-obstacles with N spheres ~100 m away vs without them.

Each case runs in a fresh interpreter (the compiled-model caches warm from an earlier run,
as a user meets them), in the same run of this script so the ratios are comparable on a
shared machine: wall time of ``plan()`` and peak resident memory of the process. The
obstacles are culled before the planner's model is built (:mod:`mmplan.planners.culling`);
before culling, 300 such spheres took 42 s and 0.6 GB (no spheres: 0.9 s, 0.08 GB) and the
issue measured 2000 at 136 s and 8 GB. Target: 2000 far spheres plan like none (ratio ~1).
Run: ``python bench/bench_culling.py [counts...]`` (default 0 300 2000).
"""

from __future__ import annotations

import subprocess
import sys

CODE = """
import resource, sys, time
from dataclasses import replace
import mmplan
from mmplan.scene import Sphere
n = int(sys.argv[1])
problem = mmplan.load_scenario("youbot3r-obstacles").build()
far = tuple(Sphere((100.0 + i % 50, 100.0 + i // 50, 0.5), 0.2) for i in range(n))
problem = replace(problem, scene=replace(problem.scene,
                                         obstacles=problem.scene.obstacles + far))
start = time.perf_counter()
result = mmplan.get_planner("extended-jacobian")().plan(problem)
wall = time.perf_counter() - start
rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6
print(f"{wall:.3f} {rss:.3f} {result.status.value} {result.info.get('obstacles_culled', 0)}")
"""


def run(count: int) -> tuple[float, float, str, str]:
    """(wall [s], peak RSS [GB], status, culled) of one fresh process."""
    out = subprocess.run([sys.executable, "-c", CODE, str(count)], check=True,
                         capture_output=True, text=True).stdout.split()
    return float(out[0]), float(out[1]), out[2], out[3]


def main() -> None:
    counts = [int(a) for a in sys.argv[1:]] or [0, 300, 2000]
    run(0)  # warm the caches
    base = run(0)
    print(f"{'far spheres':>12} {'plan() s':>9} {'ratio':>6} {'peak GB':>8} {'ratio':>6}  "
          "status   culled")
    for count in counts:
        wall, rss, status, culled = base if count == 0 else run(count)
        print(f"{count:12d} {wall:9.2f} {wall / base[0]:6.2f} {rss:8.3f} {rss / base[1]:6.2f}  "
              f"{status:8s} {culled}")


if __name__ == "__main__":
    main()
