"""The scripts in examples/ run and print what they promise."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def _run(script: str, *args: str) -> str:
    done = subprocess.run(
        [sys.executable, str(EXAMPLES / script), *args],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_robot_model_example() -> None:
    out = _run("robot_model.py")
    assert "manipulability mu(q0): 0.00974" in out
    assert "Pfaffian A(q0) N(q0) = 0: True" in out


def test_plan_and_check_example(tmp_path: Path) -> None:
    out = _run("plan_and_check.py", str(tmp_path / "plan"))
    assert "status reached" in out
    assert (tmp_path / "plan" / "trajectory.csv").is_file()
    assert (tmp_path / "plan" / "summary.json").is_file()


def test_control_loop_example() -> None:
    """The online step drives a simulated youbot-4r towards the goal within the torque limits."""
    out = _run("control_loop.py", "3")
    line = out.split("distance to goal: ")[1].splitlines()[0]  # "1.6808 m -> 0.9321 m after 3 s"
    before, after = float(line.split(" m")[0]), float(line.split("-> ")[1].split(" m")[0])
    assert after < 0.7 * before, out
    assert "torque limits exceeded by at most 0 N m" in out
    assert "NumPy fallbacks: 0" in out
