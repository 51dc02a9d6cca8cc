"""The compiled kernels of this tree against another tree's, both loaded in one process.

The machine this project is measured on drifts in speed by up to 1.7x within minutes, so two
libraries are compared call by call in one process, alternating, on the inputs a plan gives
them (the drift then hits both alike):

* the extended-Jacobian generator's chunk (``mmplan_ej_chunk_flat``): each tree plans the
  scenario in a child process that records the chunk calls' inputs and its library's path;
  the parent loads both libraries and calls each on its own recorded inputs (the same inputs
  when the plans are the same) ``--repeat`` times, alternating the order;
* the time scaling's backward and forward passes (:mod:`mmplan.time_scaling.native`): the
  other tree's module is loaded from its file, both are called on the inputs of this tree's
  plan, and their outputs are compared bit for bit.

Prints the per-call minimum of each and the median of the paired ratios (this / other), and
whether the outputs agree. Run:
``python bench/bench_kernels.py --against OLD/src [--scenario NAME] [--repeat 200]``
(OLD/src: e.g. ``git archive <commit> src | tar -x -C OLD``).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

RECORD = r"""
import json, sys
import numpy as np
import mmplan
import mmplan.planners.extended_jacobian.functions as F
seen, lib = [], []
original = F.GeneratorFunctions._native_call
def spy(self, x, *rest):  # (x) here, (x, guess_next) in older trees
    seen.append(np.array(x))
    lib.append(self.native_chunk._lib._name)
    return original(self, x, *rest)
F.GeneratorFunctions._native_call = spy
scenario = mmplan.load_scenario(sys.argv[1])
mmplan.get_planner(scenario.method)().plan(scenario.build())
np.save(sys.argv[2], np.array(seen))
print(json.dumps({"library": lib[0] if lib else None, "calls": len(seen)}))
"""


def _record(src: str, scenario: str, out: Path) -> dict[str, Any]:
    """Plan in a child process on the tree ``src``: the chunk inputs (saved to ``out``) and
    the library's path."""
    env = dict(os.environ, PYTHONPATH=src)
    run = subprocess.run([sys.executable, "-c", RECORD, scenario, str(out)], env=env,
                         capture_output=True, text=True, check=True)  # fmt: skip
    info: dict[str, Any] = json.loads(run.stdout.strip().splitlines()[-1])
    return info


def _paired(a: Callable[[], None], b: Callable[[], None], repeat: int) -> tuple[list[float], ...]:
    """Times of a and b, alternating which goes first."""
    ta: list[float] = []
    tb: list[float] = []
    for i in range(repeat):
        for fn, out in ((a, ta), (b, tb)) if i % 2 else ((b, tb), (a, ta)):
            start = time.perf_counter()
            fn()
            out.append(time.perf_counter() - start)
    return ta, tb


def _report(name: str, ta: list[float], tb: list[float], per: int, agree: str) -> None:
    ratio = statistics.median(x / y for x, y in zip(ta, tb, strict=True))
    print(f"{name:28s} this min {min(ta) / per * 1e3:.3f} ms, other min {min(tb) / per * 1e3:.3f} "
          f"ms a call; paired median this / other {ratio:.3f}; {agree}")  # fmt: skip


def chunks(against: str, scenario: str, repeat: int) -> None:
    """The generator's chunk of both trees (module docstring)."""
    from mmplan.compile.codegen import NativeFunction

    here = str(Path(__file__).resolve().parents[1] / "src")
    with tempfile.TemporaryDirectory() as tmp:
        mine, other = Path(tmp) / "this.npy", Path(tmp) / "other.npy"
        info_a, info_b = _record(here, scenario, mine), _record(against, scenario, other)
        if info_a["library"] is None or info_b["library"] is None:
            print("chunks: a tree planned without compiled chunks (no compiler?)")
            return
        xa, xb = np.load(mine), np.load(other)
    fa = NativeFunction(info_a["library"], "mmplan_ej_chunk_flat")
    fb = NativeFunction(info_b["library"], "mmplan_ej_chunk_flat")

    def run(fn: NativeFunction, xs: np.ndarray) -> Callable[[], None]:
        def go() -> None:
            for x in xs:
                fn.x[:] = x
                fn()

        return go

    # each on its own plan's inputs (the parameter layout may differ between the trees): the
    # same states, records and efforts when the plans are the same
    agree = f"{len(xa)} / {len(xb)} calls: the plans differ"
    if xa.shape[0] == xb.shape[0]:
        outs = []
        for fn, xs in ((fa, xa), (fb, xb)):
            ys = []
            for x in xs:
                fn.x[:] = x
                ys.append(fn().copy())
            outs.append(np.array(ys))
        if outs[0].shape == outs[1].shape:
            same = np.array_equal(outs[0].view(np.uint64), outs[1].view(np.uint64))
            worst = float(np.nanmax(np.abs(outs[0] - outs[1])))
            agree = "the same outputs to the bit" if same else f"outputs differ by {worst:.1e}"
    ta, tb = _paired(run(fa, xa), run(fb, xb), repeat)
    _report(f"chunk ({len(xa)} calls)", ta, tb, len(xa), agree)


def passes(against: str, scenario: str, repeat: int) -> None:
    """The time scaling's passes of both trees on this tree's plan (module docstring)."""
    import mmplan
    from mmplan.time_scaling import native

    spec = importlib.util.spec_from_file_location(
        "other_native", Path(against) / "mmplan" / "time_scaling" / "native.py"
    )
    assert spec is not None and spec.loader is not None
    old = importlib.util.module_from_spec(spec)
    sys.modules["other_native"] = old
    spec.loader.exec_module(old)
    calls: dict[str, list[tuple[Any, ...]]] = {"backward": [], "forward": []}
    originals = {k: getattr(native.Kernels, k) for k in calls}

    def spy(kind: str) -> Callable[..., Any]:
        def wrapped(self: Any, *args: Any) -> Any:
            calls[kind].append(args)
            return originals[kind](self, *args)

        return wrapped

    for kind in calls:
        setattr(native.Kernels, kind, spy(kind))
    try:
        sc = mmplan.load_scenario(scenario)
        mmplan.get_planner(sc.method)().plan(sc.build())
    finally:
        for kind, fn in originals.items():
            setattr(native.Kernels, kind, fn)
    new, other = native.kernels(), old.kernels()
    if new is None or other is None:
        print("passes: no compiled passes (no compiler?)")
        return
    for kind, args in calls.items():

        def go(k: Any, kind: str = kind, args: list[tuple[Any, ...]] = args) -> Callable[[], Any]:
            return lambda: [getattr(k, kind)(*a) for a in args]

        bits = all(np.array_equal(np.asarray(x, dtype=float).view(np.uint64),
                                  np.asarray(y, dtype=float).view(np.uint64))
                   for a in args for x, y in zip(np.atleast_2d(getattr(new, kind)(*a)),
                                                 np.atleast_2d(getattr(other, kind)(*a)),
                                                 strict=True))  # fmt: skip
        ta, tb = _paired(go(new), go(other), repeat)
        _report(f"{kind} pass ({len(args)} calls)", ta, tb, len(args),
                "the same results" if bits else "RESULTS DIFFER")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--against", required=True, help="the other tree's src folder")
    parser.add_argument("--scenario", default="youbot3r-obstacles-torque")
    parser.add_argument("--repeat", type=int, default=200)
    args = parser.parse_args()
    print(f"{args.scenario}: this tree against {args.against}, {args.repeat} alternations, "
          f"load average {os.getloadavg()[0]:.2f}")  # fmt: skip
    chunks(args.against, args.scenario, args.repeat)
    passes(args.against, args.scenario, args.repeat)


if __name__ == "__main__":
    main()
