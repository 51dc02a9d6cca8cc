"""The planner's second core: guessed chunks on and off, and the time scaling's backward pass
on one thread or two, each pair interleaved in one run, with 0, 1 and 2 busy processes beside.

* Guesses (:mod:`mmplan.planners.extended_jacobian.prefetch`): ``--plans`` warm plans of the
  scenario (default youbot3r-obstacles-torque) in one process, guesses forced on and off
  alternately (their load gate switched off); median and best of each and the ratio on / off
  of the medians; and as shipped (``default``: the load gate on, guesses and the split only
  while a core is idle), interleaved with them.
* Backward pass (:mod:`mmplan.time_scaling.native`): the full pass over the plan's first
  re-timing rows (606 intervals x 15 rows for the paper scenario), split over two threads
  (forced: the load gate ``threads.idle_core`` switched off) against one thread.

Busy processes are plain Python loops (``--load`` counts to run, default 0 1 2). Run:
``python bench/bench_threads.py [--plans 30] [--load 0 1 2]``.
"""

from __future__ import annotations

import argparse
import ctypes
import os
import statistics
import subprocess
import sys
import time

import numpy as np

import mmplan
from mmplan.compile import codegen, threads
from mmplan.planners.extended_jacobian.functions import GeneratorFunctions
from mmplan.time_scaling import native, retime

BUSY = "while True: pass"


def _busy(count: int) -> list[subprocess.Popen[bytes]]:
    return [subprocess.Popen([sys.executable, "-c", BUSY]) for _ in range(count)]


def _rows(planner: object, problem: object) -> tuple[np.ndarray, ...]:
    """The first backward pass's inputs of a plan (captured from topp.scaling_with_sets)."""
    seen: list[tuple[np.ndarray, ...]] = []
    original = native.Kernels.backward

    def spy(self: native.Kernels, *args: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if not seen:
            seen.append(tuple(np.array(a) for a in args[:6]) + (args[6], args[7]))  # type: ignore[arg-type]
        return original(self, *args)  # type: ignore[arg-type]

    rounds = retime._compiled_rounds  # the rounds in NumPy: their passes are called apart
    native.Kernels.backward = spy  # type: ignore[method-assign]
    retime._compiled_rounds = lambda *a, **k: None  # type: ignore[assignment]
    try:
        planner.plan(problem)  # type: ignore[attr-defined]
    finally:
        native.Kernels.backward = original  # type: ignore[method-assign]
        retime._compiled_rounds = rounds  # type: ignore[assignment]
    return seen[0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="youbot3r-obstacles-torque")
    parser.add_argument("--plans", type=int, default=30)
    parser.add_argument("--load", type=int, nargs="*", default=[0, 1, 2])
    args = parser.parse_args()
    sc = mmplan.load_scenario(args.scenario)
    problem = sc.build()
    planner = mmplan.get_planner(sc.method)()
    planner.plan(problem)
    fns = planner._prepare(problem).fns  # type: ignore[attr-defined]
    assert isinstance(fns, GeneratorFunctions) and fns.native_chunk is not None
    spec = fns._speculate()
    spec.switch(True)
    assert spec.enabled, "no guesses: one core, or the thread helper is missing"
    data = _rows(planner, problem)
    path = codegen.compile_source(native.SOURCE, native.PREFIX, native.FLAGS)
    assert path is not None
    shipped, single = (native.Kernels(ctypes.CDLL(path)) for _ in range(2))
    single.split = False
    gate = threads.idle_core
    forced = lambda: True  # noqa: E731  # split whatever the load
    threads.idle_core = forced  # type: ignore[assignment]
    top = len(data[0]) - 2
    print(f"{args.scenario}: {args.plans} plans each way; backward pass {top + 1} intervals x "
          f"{data[0].shape[1]} rows; {threads.cores()} cores")  # fmt: skip
    for load in args.load:
        procs = _busy(load)
        try:
            time.sleep(1.0)
            times: dict[str, list[float]] = {"on": [], "off": [], "default": []}
            for i in range(3 * args.plans):
                case = ("on", "off", "default")[i % 3]
                spec.switch(case != "off")
                spec.follow_load = case == "default"  # as shipped: the gate decides
                threads.idle_core = gate if case == "default" else forced  # type: ignore[assignment]
                start = time.perf_counter()
                planner.plan(problem)
                times[case].append(time.perf_counter() - start)
            spec.switch(True)
            threads.idle_core = forced  # type: ignore[assignment]
            bw: dict[str, list[float]] = {"two threads": [], "one thread": []}
            for _ in range(40):
                for name, kernels in (("two threads", shipped), ("one thread", single)):
                    start = time.perf_counter()
                    kernels.backward(*data[:6], data[6], top)
                    bw[name].append(time.perf_counter() - start)
        finally:
            for p in procs:
                p.kill()
        on_m, off_m, def_m = (statistics.median(times[k]) * 1e3 for k in ("on", "off", "default"))
        print(f"busy processes {load} (load average {os.getloadavg()[0]:.2f}):")
        print(f"  plan, guesses on : median {on_m:6.2f} ms, best {min(times['on']) * 1e3:6.2f}")
        print(f"  plan, guesses off: median {off_m:6.2f} ms, best {min(times['off']) * 1e3:6.2f}"
              f"   on / off {on_m / off_m:.3f}")  # fmt: skip
        print(f"  plan as shipped  : median {def_m:6.2f} ms, best "
              f"{min(times['default']) * 1e3:6.2f}   shipped / off {def_m / off_m:.3f}")
        two, one = (statistics.median(bw[k]) * 1e3 for k in ("two threads", "one thread"))
        print(f"  backward pass: two threads {two:.3f} ms, one thread {one:.3f} ms, "
              f"two / one {two / one:.3f}")  # fmt: skip


if __name__ == "__main__":
    main()
