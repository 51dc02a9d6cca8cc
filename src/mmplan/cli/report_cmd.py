"""``mmplan report DIR``: the report, and the plan's independent check alongside it.

Imported only by that command (it needs the optional report extra). The check runs in a
forked child process (:mod:`mmplan.report.background`) while this one draws, so a plan that
fails its checks is named in a warning without making the report slower.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from mmplan.report import check_failures, write_report
from mmplan.report.background import Background
from mmplan.report.file_figures import start_file_figures


def write_checked_report(plan_dir: Path, step: Callable[[str], None]
                         ) -> tuple[Path, list[str]]:
    """Write ``plan_dir/report.html``; also what ``mmplan check plan_dir`` would report as
    failed (empty when the plan passes).

    Args:
        plan_dir: A plan directory.
        step: Called with the name of each step as it starts (the progress line).

    Raises:
        InputError: ``plan_dir`` is no readable plan directory.
    """
    files = start_file_figures(plan_dir)  # matplotlib, then a child draws from the files alone
    # what both the check and the report load (NumPy, CasADi, pydantic, the scenario and the
    # robot models: 0.4 s), loaded once before the fork; the child checks while this process
    # draws
    import mmplan.io.plan_folder
    import mmplan.report.context
    import mmplan.verify.check  # noqa: F401

    checking = Background(lambda: check_failures(plan_dir))
    try:
        page = write_report(plan_dir, step=step, files_job=files)
        step("checking the plan")
        failed = checking.result()
    finally:
        checking.cancel()
        files.cancel()
    return page, failed
