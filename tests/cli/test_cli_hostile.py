"""CLI edges of issue 16: every bad argument is one ``error:`` line with exit 2 (click's usage
errors included), paths the system refuses are bad input (not exit 1), and `mmplan check` on
unreadable files says so in one line."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.cli.test_cli import run
from tests.cli.test_cli_review import _reached

LONG = "d" * 300  # one path component longer than NAME_MAX (255): ENAMETOOLONG


def one_error_line(result_stderr: str) -> str:
    lines = result_stderr.strip().splitlines()
    assert len(lines) == 1, result_stderr
    line = lines[0]
    assert line.startswith("error: ") and len(line) <= 500 and "Traceback" not in line, line
    return line


@pytest.mark.parametrize(("args", "expected"), [
    (["plan", "x.yaml"], "error: Missing option '--out'. (see '"),
    (["plan"], "error: Missing argument 'SCENARIO'."),
    (["plan", "x.yaml", "--out", "o", "--format", "xml"],
     "error: Invalid value for '--format': 'xml' is not one of 'csv', 'npz'."),
    (["plan", "x.yaml", "--out", "FILE"], "error: Invalid value for '--out': Directory '"),
    (["plan", "x.yaml", "--out", "o", "--bogus"], "error: No such option '--bogus'"),
    (["check"], "error: Missing argument 'DIRECTORY'."),
    (["report"], "error: Missing argument 'PLAN_DIR'."),
    (["reproduce"], "error: Missing option '--out'."),
    (["robots", "extra"], "error: Got unexpected extra argument (extra)"),
    (["nosuch"], "error: No such command 'nosuch'."),
])
def test_usage_errors_are_one_line(tmp_path: Path, args: list[str], expected: str) -> None:
    """Before: a usage block, a hint and the message (4 lines)."""
    file = tmp_path / "a-file"
    file.write_text("x")
    result = run(*[str(file) if a == "FILE" else a for a in args])
    assert result.exit_code == 2, result.output
    assert "Usage:" not in result.output
    assert one_error_line(result.stderr).startswith(expected), result.stderr


def test_help_is_still_help() -> None:
    result = run("plan", "--help")
    assert result.exit_code == 0 and "Usage:" in result.stdout
    result = run()  # bare `mmplan`: the help text (click's exit code 2)
    assert "Commands:" in result.output


def test_a_too_long_out_is_refused_before_planning(tmp_path: Path) -> None:
    """Before: exit 1 (OSError ENAMETOOLONG) after planning."""
    out = tmp_path / LONG
    result = run("plan", str(_reached(tmp_path)), "--out", str(out), "-q")
    assert result.exit_code == 2
    line = one_error_line(result.stderr)
    assert line.startswith("error: --out: ") and line.endswith(": File name too long"), line
    assert f"({len(str(out))} characters)" in line  # the path is shortened, not 300+ characters
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scenario.yaml"]


@pytest.mark.parametrize("command", [["check"], ["report"], ["reproduce", "--out"]])
def test_a_too_long_path_is_bad_input(tmp_path: Path, command: list[str]) -> None:
    """Before: exit 1 (internal error: OSError: [Errno 36] File name too long)."""
    result = run(*command, str(tmp_path / LONG))
    assert result.exit_code == 2, result.output
    assert one_error_line(result.stderr).endswith(": File name too long")


def test_a_too_long_scenario_name_is_bad_input(tmp_path: Path) -> None:
    result = run("plan", str(tmp_path / LONG), "--out", str(tmp_path / "o"))
    assert result.exit_code == 2
    assert "no such file and no built-in scenario" in one_error_line(result.stderr)


@pytest.mark.parametrize(("out", "expected"), [
    ("FILE/sub", "is not a directory"),
    ("/proc/self/mmplan-out", "not writable"),
])
def test_an_unwritable_out_is_refused_before_planning(tmp_path: Path, out: str,
                                                      expected: str) -> None:
    file = tmp_path / "a-file"
    file.write_text("x")
    result = run("plan", str(_reached(tmp_path)), "--out", out.replace("FILE", str(file)), "-q")
    assert result.exit_code == 2
    line = one_error_line(result.stderr)
    assert line.startswith("error: --out: cannot create ") and expected in line, line


@pytest.fixture
def plan_dir(tmp_path: Path) -> Path:
    out = tmp_path / "run"
    assert run("plan", str(_reached(tmp_path)), "--out", str(out), "-q").exit_code == 0
    return out


@pytest.mark.parametrize(("name", "content", "expected"), [
    ("summary.json", b'{"status": "reached\xff\xfe"}', "summary.json: not UTF-8 text (byte 19"),
    ("summary.json", b"[" * 100_000 + b"]" * 100_000, "summary.json: malformed JSON: maximum "
                                                      "recursion depth exceeded"),
    ("summary.json", b'{"samples": ' + b"9" * 5000 + b"}", "summary.json: malformed JSON: "
                                                           "Exceeds the limit (4300 digits)"),
    ("summary.json", b"", "summary.json: malformed JSON: Expecting value"),
    ("trajectory.csv", b"t,q.x\n\xff\xfe1,2\n", "trajectory.csv: not UTF-8 text"),
    ("trajectory.csv", b"t,q.x\nabc,1\n", "trajectory.csv: malformed numbers: could not convert"),
])
def test_check_of_an_unreadable_file_is_one_line(plan_dir: Path, name: str, content: bytes,
                                                 expected: str) -> None:
    """Before: a non-UTF-8 or deeply nested summary.json ended with exit 1."""
    (plan_dir / name).write_bytes(content)
    result = run("check", str(plan_dir))
    assert result.exit_code == 2, result.output
    assert expected in one_error_line(result.stderr)


def absurd_rows(plan_dir: Path, value: str) -> None:
    """trajectory.csv with 3 samples (t = 0, 0.1, 0.2) whose other columns are all ``value``."""
    header = (plan_dir / "trajectory.csv").read_text().splitlines()[0]
    rows = [",".join([f"{0.1 * i:g}"] + [value] * (len(header.split(",")) - 1)) for i in range(3)]
    (plan_dir / "trajectory.csv").write_text(header + "\n" + "\n".join(rows) + "\n")


@pytest.mark.parametrize("value", ["1e100", "-1e12"])
def test_check_of_absurd_numbers_prints_only_fail_lines(plan_dir: Path, value: str) -> None:
    """Huge numbers: failed checks (exit 3), one line each, no RuntimeWarning lines."""
    absurd_rows(plan_dir, value)
    result = run("check", str(plan_dir))
    assert result.exit_code == 3, result.output
    lines = result.stderr.strip().splitlines()
    assert lines and all(line.startswith("FAIL ") and len(line) <= 500 for line in lines), lines


@pytest.mark.parametrize("value", ["nan", "inf", "1e200"])
def test_check_of_non_finite_samples_is_a_failed_check(plan_dir: Path, value: str) -> None:
    absurd_rows(plan_dir, value)
    result = run("check", str(plan_dir))
    assert result.exit_code == 3, result.output
    assert "FAIL finite" in result.stderr or "FAIL" in result.stderr


def test_check_fail_lines_are_bounded(plan_dir: Path) -> None:
    summary = json.loads((plan_dir / "summary.json").read_text())
    summary["status"] = "x\n" * 100_000
    (plan_dir / "summary.json").write_text(json.dumps(summary))
    result = run("check", str(plan_dir))
    assert result.exit_code == 3
    lines = result.stderr.strip().splitlines()
    assert all(line.startswith("FAIL ") and len(line) <= 500 for line in lines), lines
