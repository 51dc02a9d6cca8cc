"""The re-timing of a plan's path: the tightening rounds as one C call against the NumPy loop.

Captures the planner's call of ``retime_path`` (youbot3r-obstacles-torque by default: 607
samples, four rounds), then calls it alternately with the compiled rounds
(``time_scaling/native_rounds.py``) and with the NumPy loop of ``time_scaling/retime.py``, in one
process (the machine's drift cancels), and says whether the results are the same bits.

    python bench/bench_retime.py [--scenario NAME] [--repeat 60]
"""

from __future__ import annotations

import argparse
import statistics
import time
from typing import Any

import numpy as np

import mmplan
import mmplan.planners.extended_jacobian.time_scaling as ej_time_scaling
from mmplan.time_scaling import retime


def _captured(name: str) -> tuple[tuple[Any, ...], dict[str, Any]]:
    seen: list[tuple[tuple[Any, ...], dict[str, Any]]] = []
    original = ej_time_scaling.retime_path

    def grab(*args: Any, **kwargs: Any) -> Any:
        seen.append((args, kwargs))
        return original(*args, **kwargs)

    ej_time_scaling.retime_path = grab  # type: ignore[assignment]
    try:
        scenario = mmplan.load_scenario(name)
        mmplan.get_planner(scenario.method)().plan(scenario.build())
    finally:
        ej_time_scaling.retime_path = original  # type: ignore[assignment]
    if not seen:
        raise SystemExit(f"{name}: the plan was not re-timed")
    return seen[0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="youbot3r-obstacles-torque")
    parser.add_argument("--repeat", type=int, default=60)
    args = parser.parse_args()
    call_args, call_kwargs = _captured(args.scenario)
    compiled_rounds = retime._compiled_rounds

    def numpy_rounds(*a: Any, **k: Any) -> None:
        return None

    times: dict[str, list[float]] = {"C": [], "NumPy": []}
    results: dict[str, retime.Retimed] = {}
    for i in range(2 * args.repeat):
        name = ("C", "NumPy")[(i + i // 2) % 2]  # alternated, each first half the time
        retime._compiled_rounds = compiled_rounds if name == "C" else numpy_rounds  # type: ignore[assignment]
        start = time.perf_counter()
        results[name] = retime.retime_path(*call_args, **call_kwargs)
        times[name].append(time.perf_counter() - start)
    retime._compiled_rounds = compiled_rounds  # type: ignore[assignment]
    a, b = results["C"], results["NumPy"]
    fields = ("x", "v", "t")
    same = (all(np.array_equal(getattr(a.scaling, f), getattr(b.scaling, f)) for f in fields)
            and np.array_equal(a.dq, b.dq) and np.array_equal(a.ddq, b.ddq)
            and a.rounds == b.rounds)  # fmt: skip
    c, p = (statistics.median(times[k]) * 1e3 for k in ("C", "NumPy"))
    print(f"{args.scenario}: re-timing of {len(call_args[0])} samples, {a.rounds} rounds, "
          f"{args.repeat} calls each way, alternated")  # fmt: skip
    print(f"  rounds in C   : median {c:.3f} ms, best {min(times['C']) * 1e3:.3f} ms")
    print(f"  NumPy loop    : median {p:.3f} ms, best {min(times['NumPy']) * 1e3:.3f} ms")
    print(f"  C / NumPy {c / p:.3f}; the same bits: {same}")


if __name__ == "__main__":
    main()
