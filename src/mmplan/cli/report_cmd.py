"""``mmplan report DIR``: the report, and the plan's independent check alongside it.

Imported only by that command (it needs the optional report extra). The check runs in the
forked child process that loads the robot and scene models for the report
(:func:`mmplan.report.build.write_report_and`), after the 3D view, while this process draws,
so a plan that fails its checks is named in a warning without making the report slower.
"""

from __future__ import annotations

import gc
from collections.abc import Callable
from pathlib import Path

from mmplan.report import check_failures, quiet_numerics


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
    from mmplan.report.build import write_report_and

    # A command's short life: the cyclic garbage collector would walk matplotlib's and the
    # models' objects over and over for little to free (measured: 4 % of the CPU time).
    collecting = gc.isenabled()
    gc.disable()
    try:
        with quiet_numerics():
            return write_report_and(plan_dir, lambda: check_failures(plan_dir), step=step,
                                    also_step="checking the plan")
    finally:
        if collecting:  # what is alive now stays (a collection of it all would take longer)
            gc.freeze()
            gc.enable()
