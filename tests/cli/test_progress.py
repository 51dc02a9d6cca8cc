"""Progress of the command's long steps: one live line on a terminal's stderr, shown once a
step has run a second; nothing without a terminal or with --quiet; never on stdout."""

from __future__ import annotations

import io
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
from rich.console import Console

from mmplan.cli import output
from mmplan.cli import progress as progress_module
from mmplan.cli.progress import Progress, live_on
from tests.cli.test_cli import _reachable_goal, changed, run, write

ROOT = Path(__file__).resolve().parents[2]


def _terminal() -> tuple[Console, io.StringIO]:
    buffer = io.StringIO()
    return Console(file=buffer, force_terminal=True, width=120, highlight=False), buffer


def _wait_until_shown(bar: Progress, count: int = 1) -> None:
    for _ in range(500):
        if len(bar.shown) >= count:
            return
        time.sleep(0.01)
    raise AssertionError(f"shown: {bar.shown}")


def test_a_step_shows_only_once_it_has_run_the_delay() -> None:
    console, buffer = _terminal()
    quick = Progress(True, delay=60.0, console=console)
    quick("reading the plan")
    quick.close()
    assert quick.shown == [] and buffer.getvalue() == ""
    slow = Progress(True, delay=0.0, console=console)
    slow("writing the ROS 2 bag")
    _wait_until_shown(slow)
    assert slow.live
    slow.close()
    assert not slow.live and slow.shown == ["writing the ROS 2 bag"]
    assert "writing the ROS 2 bag" in buffer.getvalue()


def test_a_timer_of_an_ended_step_shows_nothing() -> None:
    console, buffer = _terminal()
    stale = Progress(True, delay=60.0, console=console)
    stale("reading the plan")
    generation = stale._generation
    stale.close()
    stale._appear(generation)  # the timer fires just as its step ended
    assert stale.shown == [] and not stale.live and buffer.getvalue() == ""


def test_later_steps_replace_the_line_and_a_fraction_draws_a_percentage() -> None:
    console, buffer = _terminal()
    with Progress(True, delay=0.0, console=console) as bar:
        bar("planning")
        bar.fraction(0.25)  # before the line shows (or just after): kept for it
        _wait_until_shown(bar)
        bar._live.refresh()  # type: ignore[union-attr]
        assert " 25%" in buffer.getvalue()
        bar.fraction(0.5)
        bar._live.refresh()  # type: ignore[union-attr]
        assert " 50%" in buffer.getvalue()
        bar.step("writing the plan")  # the line is up: shown at once
        assert bar.shown == ["planning", "writing the plan"]
        bar.describe("writing the plan (2/3)")  # new words, same step
        bar._live.refresh()  # type: ignore[union-attr]
        assert "writing the plan (2/3)" in buffer.getvalue()
        assert bar.shown == ["planning", "writing the plan"]
    text = buffer.getvalue()
    assert "planning" in text and "writing the plan" in text
    assert not bar.live


def test_disabled_shows_nothing() -> None:
    console, buffer = _terminal()
    off = Progress(False, delay=0.0, console=console)
    off("x")
    off.fraction(0.5)
    time.sleep(0.05)
    off.close()
    assert off.shown == [] and buffer.getvalue() == ""


def test_live_only_on_a_terminal_and_never_when_quiet(monkeypatch: pytest.MonkeyPatch) -> None:
    console, _ = _terminal()
    monkeypatch.setattr(output, "err", console)
    assert live_on(quiet=False) and not live_on(quiet=True)
    monkeypatch.setattr(output, "err", Console(file=io.StringIO()))
    assert not live_on(quiet=False)


@pytest.fixture
def terminal(monkeypatch: pytest.MonkeyPatch) -> io.StringIO:
    """stderr of the command is a terminal (a buffer) and every step shows at once."""
    console, buffer = _terminal()
    monkeypatch.setattr(output, "err", console)
    monkeypatch.setattr(progress_module, "DELAY_S", 0.0)
    monkeypatch.setattr(Progress.__init__, "__defaults__", (0.0, None))
    return buffer


def _scenario(tmp_path: Path, sleep_s: float = 0.0) -> Path:
    data = changed("goal", {"position": _reachable_goal(0.5), "tolerance": 0.005})
    data["planner"] = {**data["planner"], "sleep_s": sleep_s}
    return write(tmp_path, data)


def test_plan_check_and_report_name_their_steps_on_a_terminal(
    tmp_path: Path, terminal: io.StringIO
) -> None:
    out = tmp_path / "plan"
    result = run("plan", str(_scenario(tmp_path, sleep_s=0.4)), "--out", str(out), "--report")
    assert result.exit_code == 0, result.output
    shown = terminal.getvalue()
    for step in ("planning", "checking and writing the plan", "drawing the figures"):
        assert step in shown, step
    assert "planning" not in result.stdout and result.stderr == ""  # never on stdout
    assert result.stdout.startswith("status: reached")
    terminal.seek(0)
    terminal.truncate()
    result = run("check", str(out))
    assert result.exit_code == 0 and "checking the plan" in terminal.getvalue()
    assert result.stdout.rstrip().endswith("check passed")
    terminal.seek(0)
    terminal.truncate()
    result = run("report", str(out))
    assert result.exit_code == 0 and result.stdout.startswith(f"wrote {out / 'report.html'}")
    assert "checking the plan" in terminal.getvalue()


def test_quiet_shows_no_progress_and_prints_failures_only(
    tmp_path: Path, terminal: io.StringIO
) -> None:
    out = tmp_path / "plan"
    assert run("plan", str(_scenario(tmp_path)), "--out", str(out), "-q").exit_code == 0
    for command in (("check", str(out), "-q"), ("report", str(out), "--quiet")):
        result = run(*command)
        assert result.exit_code == 0 and result.output == "", command
    assert terminal.getvalue() == ""


def test_no_progress_without_a_terminal(tmp_path: Path,
                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """CliRunner's stderr is no terminal: every step may take its time, stderr stays empty."""
    monkeypatch.setattr(Progress.__init__, "__defaults__", (0.0, None))
    out = tmp_path / "plan"
    for command in (("plan", str(_scenario(tmp_path, sleep_s=0.4)), "--out", str(out)),
                    ("check", str(out)), ("report", str(out))):
        result = run(*command)
        assert result.exit_code == 0 and result.stderr == "", (command, result.stderr)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="needs a pseudo-terminal")
def test_a_real_terminal_sees_the_planning_line(tmp_path: Path) -> None:
    """The command in a pseudo-terminal (stderr) with a plan that takes about 1.5 s: the
    planning line appears on stderr, stdout (a pipe) gets the results only."""
    import pty

    master, slave = pty.openpty()
    code = "import sys, tests.eta_planner; from mmplan.cli.main import main; sys.exit(main())"
    proc = subprocess.Popen([sys.executable, "-c", code, "plan",
                             str(_scenario(tmp_path, sleep_s=3.0)), "--out",
                             str(tmp_path / "o")], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=slave, text=True, env={**os.environ, "COLUMNS": "100"})
    os.close(slave)
    seen = b""
    while True:
        try:
            chunk = os.read(master, 4096)
        except OSError:  # the command ended: the terminal is closed
            break
        if not chunk:
            break
        seen += chunk
    stdout, _ = proc.communicate(timeout=120)
    os.close(master)
    assert proc.returncode == 0
    assert b"planning" in seen
    assert stdout.startswith("status: reached") and "planning" not in stdout


def test_reproduce_lists_each_run_and_names_it_on_the_progress_line(
    tmp_path: Path, terminal: io.StringIO
) -> None:
    result = run("reproduce", "--out", str(tmp_path / "r"), "--only", "car-rtr-free",
                 "--no-report", "-j", "1")
    assert result.exit_code == 0, result.output
    assert result.stdout.startswith("ok   car-rtr-free ")
    assert "car-rtr-free (1/1)" in terminal.getvalue() and result.stderr == ""
    quiet = run("reproduce", "--out", str(tmp_path / "q"), "--only", "car-rtr-free",
                "--no-report", "-q")
    assert quiet.exit_code == 0 and "car-rtr-free" not in quiet.stdout  # only failed runs
    assert "numbers compared" in quiet.stdout.splitlines()[0]
