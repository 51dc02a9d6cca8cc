"""What a report loads: not meshcat's server (ZeroMQ, tornado, IPython), not SciPy, not the
URDF package for a built-in robot (together 0.6 s of `mmplan report`); meshcat stays usable.
The process of `mmplan report` that draws loads no robot or scene model (its child does)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from tests.report.plans import PAPER_OBSTACLES, make_plan_dir

CODE = """
import sys
from mmplan.report import write_report
write_report({folder!r}, parallel=False)
print(sorted({{m.split('.')[0] if not m.startswith(('meshcat', 'mmplan')) else m
              for m in sys.modules
              if m.startswith(('meshcat.visualizer', 'meshcat.servers', 'zmq', 'tornado',
                               'IPython', 'scipy', 'mmplan.robot.urdf'))}}))
import meshcat  # the real package, after the report loaded its parts alone
print(meshcat.Visualizer.__name__, meshcat.geometry.Box.__name__)
"""


def test_a_report_loads_no_server_no_scipy_no_urdf_package(tmp_path: Path) -> None:
    obstacles = [PAPER_OBSTACLES[1], PAPER_OBSTACLES[2]]  # a superellipsoid's exact distance seeds
    assert [o["shape"] for o in obstacles] == ["sphere", "cylinder"]  # with SciPy's k-d tree
    folder = make_plan_dir(tmp_path / "plan", obstacles=obstacles)
    run = subprocess.run([sys.executable, "-c", CODE.format(folder=str(folder))],
                         capture_output=True, text=True, check=False)
    assert run.returncode == 0, run.stderr[-2000:]
    loaded, usable = run.stdout.strip().splitlines()
    assert loaded == "[]"
    assert usable == "Visualizer Box"


DRAWER = """
import sys
from pathlib import Path
from mmplan.cli.report_cmd import write_checked_report
page, failed = write_checked_report(Path({folder!r}), lambda step: None)
print(page.name, failed)
print(sorted(m for m in ('casadi', 'pydantic', 'mmplan.robot', 'mmplan.scene', 'mmplan.task',
                         'mmplan.scenario', 'mmplan.verify', 'mmplan.report.context', 'meshcat')
             if m in sys.modules))
"""


def test_the_drawing_process_loads_no_models(tmp_path: Path) -> None:
    from mmplan.report.background import can_fork

    folder = make_plan_dir(tmp_path / "plan")
    run = subprocess.run([sys.executable, "-c", DRAWER.format(folder=str(folder))],
                         capture_output=True, text=True, check=False)
    assert run.returncode == 0, run.stderr[-2000:]
    written, loaded = run.stdout.strip().splitlines()
    assert written.startswith("report.html [")
    assert (folder / "report.html").is_file()
    if can_fork():  # the models are loaded by the child alone
        assert loaded == "[]"
