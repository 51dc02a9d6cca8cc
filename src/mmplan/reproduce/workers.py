"""Calls run at the same time in forked worker processes, their progress sent back.

:func:`in_workers` runs ``job(*args, note)`` for every argument tuple in a pool of forked
processes (Linux; :func:`can_fork`). ``note(label, fraction)`` inside a job reaches the
caller's ``progress(index, label, fraction)`` through a queue; each result reaches
``done(index, result)`` as it finishes, a job whose process died ``failed(index, why)``.
The job must be a module-level function (it is sent to the workers by reference).
"""

from __future__ import annotations

import multiprocessing
import os
import sys
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from queue import Empty
from typing import Any, TypeVar

R = TypeVar("R")
#: A job's progress callback: (label, fraction of the job done).
Report = Callable[[str, float], None]

_queue: Any = None  # a worker's channel back to the caller (set by _start)
_index = 0  # the index of the job a worker runs


def can_fork() -> bool:
    """Worker processes can be forked (Linux)."""
    return sys.platform.startswith("linux") and hasattr(os, "fork")


def _start(queue: Any) -> None:
    global _queue
    _queue = queue


def _note(label: str, fraction: float) -> None:
    _queue.put((_index, label, float(fraction)))


def _call(i: int, job: Callable[..., R], args: tuple[Any, ...]) -> R:
    global _index
    _index = i
    return job(*args, _note)


def in_workers(job: Callable[..., R], calls: Sequence[tuple[Any, ...]], jobs: int,
               progress: Callable[[int, str, float], None],
               failed: Callable[[int, str], None], done: Callable[[int, R], None]) -> None:
    """``job(*args, note)`` for each ``args`` in ``calls``, ``jobs`` at a time (module
    docstring). Returns when every call has finished."""
    context = multiprocessing.get_context("fork")
    queue = context.Queue()
    finished_ones: set[int] = set()

    def drain() -> None:
        while True:
            try:
                i, label, fraction = queue.get_nowait()
            except Empty:
                return
            if i not in finished_ones:
                progress(i, label, fraction)

    with ProcessPoolExecutor(jobs, mp_context=context, initializer=_start,
                             initargs=(queue,)) as pool:
        pending = {pool.submit(_call, i, job, args): i for i, args in enumerate(calls)}
        while pending:
            ready, _ = wait(pending, timeout=0.1, return_when=FIRST_COMPLETED)
            drain()
            for future in ready:
                i = pending.pop(future)
                finished_ones.add(i)
                try:
                    result = future.result()
                except Exception as exc:  # the process died: the other calls go on
                    failed(i, f"the worker process failed ({type(exc).__name__})")
                else:
                    done(i, result)
    queue.close()
