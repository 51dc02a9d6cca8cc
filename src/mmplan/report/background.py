"""Run one job in a forked child process while the caller does other work (Linux only).

A report draws a dozen matplotlib figures (about 0.1 s each, all in Python) and builds the 3D
view; on a machine with two cores the figures are drawn by three processes (this one and two
forked children, see :mod:`mmplan.report.build`) and ``mmplan report`` checks the plan in a
fourth, so both cores work while the models load and while drawing. The child inherits everything
in memory (no pickling of the job, only of its result, sent back through a pipe) and leaves
with ``os._exit``. Where ``fork`` is unavailable or unsafe (Windows, macOS) or the child fails,
the job simply runs in the calling process when its result is asked for, so the outcome
(including any exception) is the same as without a child.
"""

from __future__ import annotations

import os
import pickle
import sys
from collections.abc import Callable
from typing import Generic, TypeVar

T = TypeVar("T")


def can_fork() -> bool:
    """True on Linux (fork is the default there and safe for this use)."""
    return sys.platform.startswith("linux") and hasattr(os, "fork")


class Background(Generic[T]):
    """``job`` started in a child process; :meth:`result` waits for it.

    Args:
        job: A function without arguments whose result can be pickled.
        enabled: Fork at all (else the job runs in :meth:`result`).
    """

    def __init__(self, job: Callable[[], T], enabled: bool = True) -> None:
        self.job = job
        self.pid = 0
        self.fd = -1
        if enabled and can_fork():
            self._start()

    def _start(self) -> None:
        read, write = os.pipe()
        pid = os.fork()
        if pid == 0:  # child: run, send ("ok", result) or ("error", text), leave at once
            os.close(read)
            try:
                try:
                    payload = pickle.dumps(("ok", self.job()), protocol=pickle.HIGHEST_PROTOCOL)
                except BaseException as exc:  # reported by re-running the job in the parent
                    payload = pickle.dumps(("error", repr(exc)))
                with os.fdopen(write, "wb") as out:
                    out.write(payload)
            finally:
                os._exit(0)
        os.close(write)
        self.pid, self.fd = pid, read

    def cancel(self) -> None:
        """Stop waiting for the child (its result is dropped); no-op without a child."""
        if self.pid:
            os.close(self.fd)  # the child's write fails and it leaves
            os.waitpid(self.pid, 0)
            self.pid = 0

    def result(self) -> T:
        """The job's result: the child's, or the job run here when there is no child or the
        child failed (then the job's exception, if any, is raised here)."""
        if self.pid:
            with os.fdopen(self.fd, "rb") as source:
                data = source.read()
            os.waitpid(self.pid, 0)
            self.pid = 0
            try:
                status, value = pickle.loads(data)
            except Exception:
                status, value = "error", None
            if status == "ok":
                return value
        return self.job()
