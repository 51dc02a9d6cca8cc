"""Import cost as a user meets it: ``import mmplan`` and ``mmplan --help`` vs their dependencies.

Each command runs in a fresh interpreter (warm disk cache), best of ``REPEAT`` runs, all in
the same run of this script so the differences are comparable on a shared machine:

* baseline: ``import numpy, casadi, pydantic, yaml`` (what mmplan cannot avoid);
* ``import mmplan`` (lazy: loads no planner, no SciPy, no matplotlib);
* ``mmplan --help`` (``python -m mmplan.cli --help``);
* ``import mmplan; mmplan.Problem`` (the core types: robot, scene, task);
* ``mmplan.get_planner("extended-jacobian")`` (one planner, what ``mmplan plan`` loads).

Target (issue: lazy imports): ``import mmplan`` at most 0.15 s above the baseline.
It also lists the heavy modules that ``import mmplan`` and ``mmplan --help`` load (none
expected: no planner, SciPy, matplotlib, rich (the console output, loaded when something is
printed) or importlib.metadata (the version, looked up for ``--version``)).
Run: ``python bench/bench_import.py``.
"""

from __future__ import annotations

import subprocess
import sys
import time

REPEAT = 7

CASES = {
    "baseline (numpy, casadi, pydantic, yaml)": "import numpy, casadi, pydantic, yaml",
    "import mmplan": "import mmplan",
    "mmplan --help": "import sys; sys.argv = ['mmplan', '--help']\n"
    "from mmplan.cli import main\ntry:\n    main()\nexcept SystemExit:\n    pass",
    "core types (mmplan.Problem)": "import mmplan; mmplan.Problem",
    "one planner (extended-jacobian)": "import mmplan; mmplan.get_planner('extended-jacobian')",
}

HEAVY = ("scipy", "matplotlib", "mmplan.planners.", "mmplan.report", "rich",
         "importlib.metadata")


def best_of(code: str) -> float:
    """Best wall time [s] of ``REPEAT`` fresh interpreters running ``code``."""
    best = float("inf")
    for _ in range(REPEAT):
        start = time.perf_counter()
        subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)
        best = min(best, time.perf_counter() - start)
    return best


def heavy_modules(code: str) -> list[str]:
    """Top-level heavy packages loaded by ``code``."""
    probe = code + "\nimport sys\nprint(' '.join(sorted(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", probe], check=True, capture_output=True,
                         text=True).stdout.split()
    return sorted({m.split(".")[0] if not m.startswith("mmplan") else m
                   for m in out if m.startswith(HEAVY)})


def main() -> None:
    times = {name: best_of(code) for name, code in CASES.items()}
    base = times["baseline (numpy, casadi, pydantic, yaml)"]
    print(f"{'case':40s} {'best [s]':>9s} {'above baseline [s]':>19s}")
    for name, value in times.items():
        print(f"{name:40s} {value:9.3f} {value - base:19.3f}")
    for name in ("import mmplan", "mmplan --help"):
        print(f"heavy modules loaded by {name}: {heavy_modules(CASES[name]) or 'none'}")


if __name__ == "__main__":
    main()
