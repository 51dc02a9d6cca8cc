"""The ``mmplan`` program: the command (:func:`mmplan.cli.main.main`), then a quick exit.

The interpreter's own teardown (freeing NumPy, CasADi, pydantic and every module object one
by one) takes ~0.1 s of CPU after each command, for nothing: a command has written its files
completely (renamed into place) and joined what it started. :func:`run` skips it when no
other thread or child process is pending (the exit handlers still run); code that calls
:func:`~mmplan.cli.main.main` itself (tests, ``CliRunner``) exits as Python does.
"""

from __future__ import annotations

import atexit
import os
import sys
import threading
from contextlib import suppress
from typing import NoReturn

from mmplan.cli.main import main


def run() -> NoReturn:
    """The ``mmplan`` program (console script, ``python -m mmplan.cli``): :func:`main`, then,
    when no other thread and no child process is pending, the exit handlers run and the
    process ends at once with its exit code, the output flushed; else Python exits as usual
    (module doc)."""
    try:
        main()
        code: object = 0
    except SystemExit as exc:
        code = exc.code
    if not _alone() or not hasattr(atexit, "_run_exitfuncs"):
        sys.exit(code)  # type: ignore[arg-type]
    # What Python does at exit, minus the teardown: the exit handlers run now, in order
    # (matplotlib, PIL and logging register some when a report is drawn: measured, refusing
    # the quick exit for them cost `mmplan report` 0.17 s wall and 0.3 s CPU).
    atexit._run_exitfuncs()
    if code is None:
        status = 0
    elif isinstance(code, int):
        status = code & 0xFF
    else:  # sys.exit("text"): the text on stderr, status 1
        print(code, file=sys.stderr)
        status = 1
    for stream in (sys.stdout, sys.stderr):
        with suppress(OSError, ValueError):  # a closed pipe (mmplan robots | head): no more
            stream.flush()
    os._exit(status)


def _alone() -> bool:
    """No other thread runs and no child process started by multiprocessing is alive (Python
    would wait for them at exit)."""
    if threading.active_count() > 1:
        return False
    mp = sys.modules.get("multiprocessing")
    return mp is None or not mp.active_children()


__all__ = ["run"]
