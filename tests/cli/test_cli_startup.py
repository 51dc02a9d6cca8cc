"""What ``mmplan plan`` loads besides planning: no console library when it prints nothing, one
robot module, the version only when asked for."""

from __future__ import annotations

import subprocess
import sys
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import yaml
from click.testing import CliRunner

from mmplan.cli.main import main
from tests.cli.test_cli import BASE

ROOT = Path(__file__).resolve().parents[2]


def test_version_option_prints_the_installed_version() -> None:
    try:
        expected = version("mmplan")
    except PackageNotFoundError:  # pragma: no cover - a source tree without metadata
        expected = "0+unknown"
    result = CliRunner().invoke(main, ["--version"])
    assert result.exit_code == 0 and result.output == f"mmplan, version {expected}\n"


def test_quiet_plan_loads_no_console_library_and_one_robot_module(tmp_path: Path) -> None:
    """``plan -q`` that succeeds prints nothing: rich (~50 ms of a start) is never imported,
    and of the built-in robot modules only the scenario's robot is."""
    scenario = tmp_path / "scenario.yaml"
    scenario.write_text(yaml.safe_dump(BASE), encoding="utf-8")
    code = (
        "import sys, tests.eta_planner\n"
        "from mmplan.cli.main import main\n"
        "try:\n"
        f"    main(['plan', {str(scenario)!r}, '--out', {str(tmp_path / 'out')!r}, '-q'])\n"
        "except SystemExit as exc:\n"
        "    assert exc.code in (0, 3, None), exc.code\n"
        "print(' '.join(sorted(m for m in sys.modules if m.split('.')[0] == 'rich'"
        " or m.startswith('mmplan.robot.library.'))))\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            timeout=300, check=False, cwd=ROOT)
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "out" / "summary.json").is_file()
    assert result.stdout.split() == ["mmplan.robot.library.youbot_3r",
                                     "mmplan.robot.library.youbot_rates"]


def _program(args: list[str], prelude: str = "") -> subprocess.CompletedProcess[str]:
    """The ``mmplan`` program (:func:`mmplan.cli.program.run`) with ``args``, output piped."""
    code = (f"import sys, tests.eta_planner\n{prelude}\n"
            "from mmplan.cli.program import run\n"
            f"sys.argv = ['mmplan', *{args!r}]\nrun()\n")
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300, check=False, cwd=ROOT)


def test_the_program_keeps_exit_codes_and_flushes_its_output(tmp_path: Path) -> None:
    """The quick exit (no interpreter teardown) keeps the exit code and the piped output."""
    scenario = tmp_path / "scenario.yaml"
    scenario.write_text(yaml.safe_dump(BASE), encoding="utf-8")
    in_process = CliRunner().invoke(main, ["plan", str(scenario), "--out", str(tmp_path / "a")])
    done = _program(["plan", str(scenario), "--out", str(tmp_path / "out")])
    assert done.returncode == in_process.exit_code == 3, done.stderr  # t_max 1 s: not reached
    assert done.stdout.startswith("status: ")
    assert done.stdout.rstrip().endswith(f"written to {tmp_path / 'out'}")
    assert (tmp_path / "out" / "summary.json").is_file()
    checked = _program(["check", str(tmp_path / "out")])
    assert checked.returncode == 0 and checked.stdout.rstrip().endswith("check passed")
    bad = _program(["plan", str(tmp_path / "missing.yaml"), "--out", str(tmp_path / "o2")])
    assert bad.returncode == 2 and bad.stdout == ""
    assert bad.stderr.startswith("error: ") and "missing.yaml" in bad.stderr


def test_the_program_exits_as_usual_while_another_thread_runs(tmp_path: Path) -> None:
    """A thread still running at the end (none of mmplan's) is waited for, as Python does."""
    marker = tmp_path / "thread-finished"
    prelude = ("import threading, time, pathlib\n"
               "def late():\n"
               "    time.sleep(0.5)\n"
               f"    pathlib.Path({str(marker)!r}).write_text('done')\n"
               "threading.Thread(target=late).start()")
    done = _program(["--version"], prelude)
    assert done.returncode == 0 and done.stdout.startswith("mmplan, version ")
    assert marker.read_text() == "done"


def test_exit_handlers_run_and_the_teardown_is_skipped() -> None:
    """Exit handlers (matplotlib, PIL and logging register some when a report is drawn; here
    also one of our own) run as at a normal exit; the interpreter's teardown (an object's
    __del__ in a module global) is skipped. A normal exit of the same code runs both."""
    code = ("import atexit, sys, matplotlib; matplotlib.use('Agg')\n"
            "import matplotlib.pyplot, PIL.Image, logging\n"
            "class Noisy:\n"
            "    def __del__(self): print('teardown', flush=True)\n"
            "keep = Noisy()\n"
            "atexit.register(print, 'handler')\n"
            "sys.argv = ['mmplan', '--version']\n"
            "from mmplan.cli import program\n"
            "program.run() if sys.argv[-1] == '--version' else None\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=ROOT, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split("\n")[1:] == ["handler", ""], done.stdout
    normal = subprocess.run([sys.executable, "-c", code.replace("program.run()", "print()")],
                            capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert normal.stdout.split() == ["handler", "teardown"], normal.stdout
