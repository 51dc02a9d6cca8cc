"""Progress of the ``mmplan`` command's long steps: one live line on stderr.

What a user of the command sees (decided for every command alike):

* stderr is a terminal: once a step has run for a second (:data:`DELAY_S`), one line shows
  its name, a bar (how far it is, where the step knows; a pulse otherwise) and the time it
  has run; later steps replace it on the same line; it is erased when the command ends, so
  only the results stay on the screen. Steps under a second never show (no flicker).
* stderr is not a terminal (a log file, a pipe, CI): nothing. Like ``git`` and ``pip``,
  the progress line is for a person watching; logs get the results and errors only (and a
  slow command piped to a file leaves no stray lines).
* ``--quiet``: nothing either, also on a terminal.

Results go to stdout, never through the live line; :meth:`Progress.print` prints a result
line while the progress line may be live (``mmplan reproduce`` lists each finished run).
While the line is up, whatever else writes to stderr (a notice, a warning) is printed above
it, not through it.
"""

from __future__ import annotations

import threading
import time
from typing import TYPE_CHECKING

from mmplan.cli import output

if TYPE_CHECKING:
    from rich.console import Console
    from rich.progress import Progress as _Live
    from rich.progress import TaskID

#: Seconds a step runs before its line shows.
DELAY_S = 1.0


def live_on(quiet: bool) -> bool:
    """Whether a command shows progress: not ``--quiet`` and stderr is a terminal."""
    return not quiet and output.err.is_terminal


class Progress:
    """The steps of one command, shown on one live line (module docstring).

    Call :meth:`step` (or the object itself: the step callbacks of the library take it) as
    each step begins, :meth:`fraction` as a step advances, :meth:`close` at the end (or use
    it as a context manager).

    Args:
        enabled: Show anything at all (:func:`live_on`).
        delay: Seconds a step runs before the line shows.
        console: Where the line goes (default: the command's stderr console).
    """

    def __init__(self, enabled: bool, delay: float = DELAY_S,
                 console: Console | None = None) -> None:
        self.enabled = enabled
        self.delay = delay
        self.console = console if console is not None else output.err
        #: Steps that were shown (in order).
        self.shown: list[str] = []
        self._lock = threading.RLock()
        self._label = ""
        self._done: float | None = None
        self._started = time.perf_counter()
        self._generation = 0
        self._timer: threading.Timer | None = None
        self._live: _Live | None = None
        self._task: TaskID | None = None

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __call__(self, label: str) -> None:
        self.step(label)

    @property
    def live(self) -> bool:
        """The line is on the screen."""
        return self._live is not None

    def step(self, label: str) -> None:
        """A new step begins (the previous one ends)."""
        if not self.enabled:
            return
        with self._lock:
            self._generation += 1
            self._label, self._done, self._started = label, None, time.perf_counter()
            if self._live is not None:
                self._show_step()
                return
            if self._timer is not None:
                self._timer.cancel()
            self._timer = threading.Timer(self.delay, self._appear, args=(self._generation,))
            self._timer.daemon = True
            self._timer.start()

    def describe(self, label: str) -> None:
        """New words for the current step (its time and bar go on)."""
        if not self.enabled:
            return
        with self._lock:
            self._label = label
            if self._live is not None and self._task is not None:
                self._live.update(self._task, description=label)

    def fraction(self, done: float) -> None:
        """How far the current step is, 0 to 1 (shown as a bar and a percentage)."""
        if not self.enabled:
            return
        with self._lock:
            self._done = min(max(float(done), 0.0), 1.0)
            if self._live is not None and self._task is not None:
                self._live.update(self._task, total=1.0, completed=self._done,
                                  percent=f"{100 * self._done:3.0f}%")

    def print(self, text: str) -> None:
        """A result line on stdout, above the live line when there is one on the screen."""
        with self._lock:
            if self._live is not None and output.out.is_terminal:
                self._live.console.print(text, markup=False, highlight=False, soft_wrap=True)
            else:
                output.out.print(text, markup=False)

    def close(self) -> None:
        """End the current step and erase the line (if shown)."""
        with self._lock:
            self._generation += 1
            if self._timer is not None:
                self._timer.cancel()
                self._timer = None
            if self._live is not None:
                self._live.stop()
                self._live, self._task = None, None

    def _appear(self, generation: int) -> None:
        """Timer: the step that armed it is still running after ``delay``: show the line."""
        with self._lock:
            if generation != self._generation or self._live is not None:
                return
            from rich.progress import BarColumn, SpinnerColumn, TextColumn, TimeElapsedColumn
            from rich.progress import Progress as _Live

            self._live = _Live(SpinnerColumn(), TextColumn("{task.description}"),
                               BarColumn(bar_width=24), TextColumn("{task.fields[percent]}"),
                               TimeElapsedColumn(), console=output.made(self.console),
                               transient=True, redirect_stdout=False, redirect_stderr=True)
            self._task = self._live.add_task(self._label, total=None, percent="")
            self._show_step()
            self._live.start()

    def _show_step(self) -> None:
        """Put the current step on the live line (the lock is held)."""
        assert self._live is not None and self._task is not None
        self._live.reset(self._task, description=self._label, total=None, percent="")
        self._live.tasks[0].start_time = self._live.get_time() - (
            time.perf_counter() - self._started)  # the step's own running time
        self.shown.append(self._label)
        if self._done is not None:
            self.fraction(self._done)
