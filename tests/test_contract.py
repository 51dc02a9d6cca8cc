"""Contract of every planner method with its built-in scenarios, through the command line.

For each registered method and each built-in scenario of that method: ``mmplan plan NAME
--out DIR`` exits 0 (reached), writes trajectory.csv and summary.json whose status agrees with
the exit code, and ``mmplan check DIR`` re-verifies the plan independently (exit 0).

The commands run in this process (click's test runner: the same argument parsing, command
code and exit codes as the installed ``mmplan``, without a Python start-up and the imports
for each of the 2 x 19 commands); the ``python -m mmplan.cli`` entry point itself is tested
in tests/cli/test_cli.py.
"""

from __future__ import annotations

import json
import traceback
from pathlib import Path

import pytest
from click.testing import CliRunner, Result

import mmplan
from mmplan.cli.main import main
from mmplan.planners import builtin_methods
from mmplan.trajectory import Status

#: Built-in scenarios documented (in their YAML header) as ending without reaching the task:
#: name -> the statuses summary.json may give. ``mmplan plan`` exits 3 for them.
NOT_REACHING: dict[str, frozenset[str]] = {}

def _scenarios_by_method() -> dict[str, list[str]]:
    by_method: dict[str, list[str]] = {method: [] for method in builtin_methods()}
    for name in mmplan.builtin_scenarios():
        method = mmplan.load_scenario(name).method
        if method in by_method:
            by_method[method].append(name)
    return by_method


BY_METHOD = _scenarios_by_method()
CASES = [(method, name) for method, names in BY_METHOD.items() for name in names]


def _cli(*args: str | Path, cwd: Path, monkeypatch: pytest.MonkeyPatch) -> Result:
    """``mmplan ARGS`` run from ``cwd``, in this process."""
    monkeypatch.chdir(cwd)
    return CliRunner().invoke(main, [str(a) for a in args])


def _log(result: Result) -> str:
    error = "".join(traceback.format_exception(*result.exc_info)) if result.exc_info else ""
    return f"stdout:\n{result.stdout}\nstderr:\n{result.stderr}\n{error}"


@pytest.mark.parametrize("method", sorted(BY_METHOD))
def test_every_method_has_a_builtin_scenario(method: str) -> None:
    assert BY_METHOD[method], f"no built-in scenario uses method {method!r}"


def test_not_reaching_names_are_builtin_scenarios() -> None:
    assert set(NOT_REACHING) <= set(mmplan.builtin_scenarios())


@pytest.mark.parametrize(("method", "name"), CASES, ids=[name for _, name in CASES])
def test_plan_and_check(
    method: str, name: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / name
    planned = _cli("plan", name, "--out", out, cwd=tmp_path, monkeypatch=monkeypatch)
    log = _log(planned)
    expected_code = 3 if name in NOT_REACHING else 0
    assert planned.exit_code == expected_code, log
    assert (out / "trajectory.csv").is_file(), log
    assert (out / "summary.json").is_file(), log

    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] in {s.value for s in Status}
    assert summary["planner"] == method
    assert summary["check_passed"] is True, summary.get("check_failures")
    if name in NOT_REACHING:
        assert summary["status"] != Status.REACHED
        assert summary["status"] in NOT_REACHING[name]
    else:
        assert summary["status"] == Status.REACHED

    checked = _cli("check", out, cwd=tmp_path, monkeypatch=monkeypatch)
    assert checked.exit_code == 0, _log(checked)
