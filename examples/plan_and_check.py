"""Plan a built-in scenario from Python, verify it independently, and write the plan files.

Run: python examples/plan_and_check.py [OUT_DIR]
"""

from __future__ import annotations

import sys
import tempfile

import mmplan

scenario = mmplan.load_scenario("car-rtr-steer30")  # [JaniakTchon], steering bounded by pi/6
problem = scenario.build()
planner = mmplan.get_planner(scenario.method)()
result = planner.plan(problem)
report = mmplan.check(result.trajectory, problem, status=result.status)
summary = report.summary(
    status=result.status, planner=result.planner, compute_time_s=result.compute_time_s
)
print(f"status {result.status}: {result.message}")
print(f"final error {summary['final_error_m']:.2e} m, compute time {result.compute_time_s:.2f} s")
print(f"max |psi| = {result.info['max_abs.psi']:.4f} rad (bound pi/6 = 0.5236)")
out = sys.argv[1] if len(sys.argv) > 1 else tempfile.mkdtemp(prefix="mmplan-")
written = mmplan.write_plan(out, result, problem, scenario)
print("wrote", written)
