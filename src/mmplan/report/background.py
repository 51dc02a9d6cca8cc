"""Run one job in a forked child process while the caller does other work (Linux only).

A report draws a dozen matplotlib figures (about 0.1 s each, all in Python), loads the robot
and scene models and builds the 3D view; on a machine with two cores this is spread over four
processes (see :mod:`mmplan.report.build`), so both cores work while the libraries load and
while drawing. The child inherits everything in memory (no pickling of the job, only of its
results, sent back through a pipe) and leaves with ``os._exit``. :class:`Background` sends one
result, :class:`Staged` a result per stage as each is ready. Where ``fork`` is unavailable or
unsafe (Windows, macOS) or the child fails, the job simply runs in the calling process when its
result is asked for, so the outcome (including any exception) is the same as without a child.
Python's cyclic garbage collector is frozen over each fork: a child collecting would otherwise
write to every object it inherited (copying the parent's memory page by page).
"""

from __future__ import annotations

import gc
import os
import pickle
import sys
from collections.abc import Callable, Iterator
from typing import BinaryIO, Generic, TypeVar

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
        pid = _fork()
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


def _fork() -> int:
    """``os.fork`` with the objects alive now out of the garbage collector's reach in the child
    (``gc.freeze``); the parent gets them back."""
    gc.freeze()
    try:
        pid = os.fork()
    except BaseException:
        gc.unfreeze()
        raise
    if pid:
        gc.unfreeze()
    return pid


class Staged(Generic[T]):
    """``job``'s stages (the items it yields) computed in a child process; :meth:`next` waits
    for the next one, so the caller can use an early stage while the child works on.

    Args:
        job: A function without arguments returning an iterator of picklable items.
        enabled: Fork at all (else the stages are computed in :meth:`next`).
    """

    def __init__(self, job: Callable[[], Iterator[T]], enabled: bool = True) -> None:
        self.job = job
        self.pid = 0
        self.source: BinaryIO | None = None
        self.received = 0
        self.local: Iterator[T] | None = None
        if enabled and can_fork():
            self._start()

    def _start(self) -> None:
        read, write = os.pipe()
        pid = _fork()
        if pid == 0:  # child: send ("ok", stage) per stage, ("error", text) on failure
            os.close(read)
            try:
                with os.fdopen(write, "wb") as out:
                    try:
                        for item in self.job():
                            pickle.dump(("ok", item), out, protocol=pickle.HIGHEST_PROTOCOL)
                            out.flush()
                    except BaseException as exc:  # reported by re-running the job in the parent
                        pickle.dump(("error", repr(exc)), out)
            finally:
                os._exit(0)
        os.close(write)
        self.pid, self.source = pid, os.fdopen(read, "rb")

    def next(self) -> T:
        """The job's next stage: the child's, or computed here when there is no child or the
        child failed (the job is then re-run here, its stages received so far skipped, and its
        exception, if any, raised here)."""
        if self.source is not None:
            try:
                status, value = pickle.load(self.source)
            except Exception:
                status, value = "error", None
            if status == "ok":
                self.received += 1
                return value
            self.cancel()
        if self.local is None:
            self.local = iter(self.job())
            for _ in range(self.received):
                next(self.local)
        self.received += 1
        return next(self.local)

    def cancel(self) -> None:
        """Stop waiting for the child (its further stages are dropped); no-op without one."""
        if self.source is not None:
            self.source.close()  # the child's next write fails and it leaves
            os.waitpid(self.pid, 0)
            self.source, self.pid = None, 0
