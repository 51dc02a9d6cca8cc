"""HTML report of a plan directory: summary, the papers' figures and a 3D animation.

Optional extra (``pip install 'mmplan[report]'``, matplotlib); imported only by report code and
the CLI, never by the core. Entry points: :func:`write_report` (library) and
:func:`render_report_cli` (``mmplan report DIR``).
"""

from mmplan.errors import MmplanError


class MissingExtraError(MmplanError, ImportError):
    """An optional dependency of the report is not installed (exit code 1, one line)."""


try:
    import matplotlib  # noqa: F401
except ImportError:  # pragma: no cover - depends on the environment
    raise MissingExtraError(
        "mmplan report needs matplotlib: pip install 'mmplan[report]'"
    ) from None

from mmplan.report.build import render_report_cli, write_report  # noqa: E402

__all__ = ["MissingExtraError", "render_report_cli", "write_report"]
