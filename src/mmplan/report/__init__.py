"""HTML report of a plan directory: summary, the papers' figures and a 3D animation.

Optional extra (``pip install 'mmplan[report]'``: matplotlib for the figures, meshcat for the
3D viewer, whose three.js bundle is inlined); imported only by report code and
the CLI, never by the core. Entry points: :func:`write_report` and :func:`check_failures`
(``mmplan report DIR``: :mod:`mmplan.cli.report_cmd`). Numerical warnings of the plotting stack
(overflow in axis scaling of extreme data, empty CSV files) are silenced: the report shows the
data as it is and errors are reported as one line. A plan that fails its independent checks
is still rendered, with a red banner in the summary and a one-line warning on stderr.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from importlib.util import find_spec
from pathlib import Path

from mmplan.errors import MmplanError


class MissingExtraError(MmplanError, ImportError):
    """An optional dependency of the report is not installed (exit code 1, one line)."""


for _extra in ("matplotlib", "meshcat"):  # the figures; the 3D viewer
    if find_spec(_extra) is None:  # pragma: no cover - depends on the environment
        from mmplan.extras import install_command

        raise MissingExtraError(f"mmplan report needs {_extra}: {install_command('report')}")


def write_report(plan_dir: str | Path, max_frames: int = 1000,
                 step: Callable[[str], None] | None = None, parallel: bool = True) -> Path:
    """Write ``plan_dir/report.html`` and ``plan_dir/figures/*.png`` (see
    :func:`mmplan.report.build.write_report`), without numerical warnings on stderr.

    The plotting stack and the models are imported on first use (half a second), not with
    the package.
    """
    from mmplan.report import build

    with quiet_numerics():
        return build.write_report(plan_dir, max_frames, step, parallel)


@contextmanager
def quiet_numerics() -> Iterator[None]:
    """Without the plotting stack's numerical warnings (RuntimeWarning, UserWarning) and
    NumPy's floating-point warnings."""
    import numpy as np

    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore", RuntimeWarning)
        warnings.simplefilter("ignore", UserWarning)
        yield


def check_failures(plan_dir: str | Path) -> list[str]:
    """What ``mmplan check DIR`` would report as failed (empty when it passes or cannot run)."""
    import mmplan
    from mmplan.verify.native import compiled_checks
    from mmplan.verify.summary import summary_disagreements

    try:
        trajectory, sc = mmplan.read_plan(plan_dir)
        claimed = mmplan.read_summary(plan_dir)
        status = claimed.get("status")
        problem = sc.build()
        with compiled_checks(problem.robot):  # the checker's C functions when on disk
            report = mmplan.check(trajectory, problem,
                                  status=None if status is None else str(status))
    except MmplanError:
        return []
    return report.failures() + summary_disagreements(claimed, report, sc.method)


__all__ = ["MissingExtraError", "check_failures", "write_report"]
