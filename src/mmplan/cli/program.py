"""The ``mmplan`` program: the command (:func:`mmplan.cli.main.main`), then a quick exit.

The interpreter's own teardown (freeing NumPy, CasADi, pydantic and every module object one
by one) takes ~0.1 s of CPU after each command, for nothing: a command has written its files
completely (renamed into place) and joined what it started. :func:`run` skips it when
nothing else is pending; code that calls :func:`~mmplan.cli.main.main` itself (tests,
``CliRunner``) exits as Python does.
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
    """The ``mmplan`` program (console script, ``python -m mmplan.cli``): :func:`main`, then
    the process ends at once with its exit code, the output flushed, when nothing else is
    pending (no other thread, no child process, no exit handler); else Python exits as
    usual (module doc)."""
    try:
        main()
        code: object = 0
    except SystemExit as exc:
        code = exc.code
    if not _alone():
        sys.exit(code)  # type: ignore[arg-type]
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
    """No other thread runs, no child process started by multiprocessing is alive and no
    exit handler is registered (``atexit``: a library's flush or cleanup; CPython tells how
    many, another Python counts as having some)."""
    if threading.active_count() > 1:
        return False
    if getattr(atexit, "_ncallbacks", lambda: 1)() != 0:
        return False
    mp = sys.modules.get("multiprocessing")
    return mp is None or not mp.active_children()


__all__ = ["run"]
