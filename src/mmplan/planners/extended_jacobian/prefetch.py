"""The next compiled chunk, run on a second core while the rollout checks the one it has.

A chunk (:mod:`~mmplan.planners.extended_jacobian.chunks`) is one call of compiled C
(``chunk_steps`` generator steps), then the rollout's checks of its samples in NumPy (finite
values, goal, stall verdict, cond(E) and cond(Jc_R), the sample log). Measured on
youbot3r-obstacles-torque (warm, nothing else running): 13 chunks a plan, 9.6 ms in C and
4.4 ms of checks. Most chunks are accepted whole, and then the next one starts exactly where
the C call left it (the state after its last step, the same parameters). :class:`Speculation`
starts that next call on a C thread (:mod:`mmplan.compile.threads`) as soon as a chunk's
call returns; the rollout takes its result when it asks for a chunk with exactly that input
(byte for byte), and otherwise waits for it and drops it. The samples are the same bits
either way (the same C function on the same input); only where the time goes changes. A
plan also starts its first chunk this way as soon as its parameters are packed
(:meth:`~mmplan.planners.extended_jacobian.functions.GeneratorFunctions.guess_chunk`), and
the interpreter, idle while it waits, runs small tasks meanwhile (:func:`while_waiting`).

Measured (``bench/bench_threads.py``: 30 warm plans each way, interleaved, three runs):
guesses on / off 0.84-0.91 of the time with no other process running, but 1.06-1.35 with one
or two busy processes beside (a new thread waits for a time slice), so guesses pause while no
core is idle (:func:`mmplan.compile.threads.idle_core`: the threads ready to run now). With
guesses the rollout takes the time of its C chunks (13 of about 0.75 ms), the checks hidden.

Nothing is started on a machine with one usable core, nor without the compiled thread
helper. One call is in flight at most, and the compiled function's buffers are used by one
thread at a time: every call goes through :meth:`Speculation.call`, which first takes or
drops the guess in flight, and a compiled function has one :class:`Speculation`
(:func:`speculation_of`). Guesses are joined before a fork and at exit. A
:class:`~mmplan.planners.extended_jacobian.functions.GeneratorFunctions` is not to be shared
between threads that plan at the same time (nor was it before: the compiled function has one
set of buffers).
"""

from __future__ import annotations

import atexit
import contextlib
import os
import weakref
from collections.abc import Callable
from typing import Any

import numpy as np

from mmplan.arrays import Array
from mmplan.compile import threads


def speculation_of(native: Any) -> Speculation:
    """The one :class:`Speculation` of a compiled function (kept on it: two over the same
    buffers would race)."""
    found = getattr(native, "_mmplan_speculation", None)
    if not isinstance(found, Speculation):
        found = Speculation(native)
        native._mmplan_speculation = found
    return found


class Speculation:
    """Calls of one compiled function (:class:`mmplan.compile.codegen.NativeFunction`), with at
    most one guessed call running ahead on a C thread.

    Args:
        native: The compiled function (input ``native.x``, output ``native.y``).
        enabled: Guess at all (default: when the process may use two cores or more). Without
            the compiled thread helper on disk it is built in the background, and no guess
            is made until it is there.
    """

    def __init__(self, native: Any, enabled: bool | None = None) -> None:
        self._native = native
        self._wanted = threads.cores() >= 2 if enabled is None else enabled
        #: Pause while no core is idle (:func:`mmplan.compile.threads.idle_core`); off when
        #: ``enabled`` was given.
        self.follow_load = enabled is None
        self._job: threads.Job | None = None
        self._guess: Array | None = None
        #: Guesses taken and dropped so far (tests, benches).
        self.hits = 0
        self.misses = 0
        _LIVE.add(self)

    def __del__(self) -> None:
        # the C thread writes into buffers this object keeps alive: never free them under it
        if getattr(self, "_guess", None) is not None:
            self._settle(None, idle=False)

    def switch(self, on: bool) -> None:
        """Guess (whatever the load) or not, from now on (benches, tests)."""
        self.settle()
        self._wanted, self.follow_load = on, False
        if not on:
            self._job = None

    @property
    def enabled(self) -> bool:
        """Guesses are made (wanted, and the thread helper is loaded)."""
        return self._ready()

    def _ready(self) -> bool:
        if self._job is not None:
            return True
        if not self._wanted:
            return False
        if not threads.ready():  # built in the background meanwhile, for later chunks
            threads.prefetch()
            return False
        try:
            self._job = threads.Job(*self._native.signature())
        except OSError:  # does not load: no guesses
            self._wanted = False
        return self._job is not None

    def guess(self, x: Array, replace: bool = False) -> None:
        """Start the call at x on a C thread (nothing when disabled or, unless ``replace``,
        when one is in flight; ``replace``: a guess in flight is joined and dropped first)."""
        if replace and self._guess is not None:
            self._settle(None, idle=False)
        if self._guess is not None or not self._ready() or self._job is None:
            return
        if self.follow_load and not threads.idle_core():
            return
        self._native.x[:] = x
        self._guess = np.array(x, dtype=float)
        self._job.start()

    def call(self, x: Array) -> Array:
        """The output at x (a copy): the guess's when it was made at exactly this x, else
        computed now (after waiting for a guess in flight, whose result is then dropped)."""
        if self._settle(x):
            self.hits += 1
            out: Array = self._native.y.copy()
            return out
        native = self._native
        native.x[:] = x
        out = native().copy()
        return out

    def settle(self) -> None:
        """Wait for a guess in flight and drop it."""
        self._settle(None)

    def _settle(self, x: Array | None, idle: bool = True) -> bool:
        """Join a guess in flight (running :func:`while_waiting`'s tasks first when ``idle``);
        True when it was made at x and succeeded."""
        guess = self._guess
        if guess is None or self._job is None:
            return False
        try:
            while idle and _IDLE and not self._job.done():  # only while the guess runs
                task = _IDLE.pop(0)
                with contextlib.suppress(Exception):  # a warm-up: left to whoever needs it
                    task()
        finally:  # joined whatever happened: the thread writes into our buffers
            code = self._job.wait()
            self._guess = None
        ok = code == 0 and x is not None and _same(guess, x)
        self.misses += 0 if ok else 1
        return ok


#: Work for the interpreter while it waits for a guess (:func:`while_waiting`).
_IDLE: list[Callable[[], object]] = []


def while_waiting(task: Callable[[], object]) -> None:
    """Run ``task`` (once) the next time a rollout waits for a guessed chunk that is still
    running, on the idle interpreter: e.g. loading the time scaling's C loops from disk
    (0.5-1 ms of a process's first plan) while a chunk computes. Only while it runs: in a
    process's first plan the first chunk is done before the rollout asks for it (its set-up is
    slower), and the task ran in full on the plan's path; the next chunks near the start's
    obstacles run 0.6-1 ms in C while the checks take 0.3 ms (measured). Never run without
    guesses (one core): the task's work is then left to whoever needs it first."""
    if task not in _IDLE:
        _IDLE.append(task)


#: Every Speculation, so that none is left running when the interpreter exits (its buffers
#: are freed then): joined by :func:`_settle_all` at exit (a guess runs for about 1 ms).
_LIVE: weakref.WeakSet[Speculation] = weakref.WeakSet()


def _settle_all() -> None:
    """Join every guess in flight (at exit: its buffers are freed; before a fork: a child
    has no such thread, and its join would return at once on buffers half written)."""
    for speculation in list(_LIVE):
        speculation._settle(None, idle=False)


atexit.register(_settle_all)
if hasattr(os, "register_at_fork"):
    os.register_at_fork(before=_settle_all)


def _same(a: Array, b: Array) -> bool:
    """The same input to the bit (NaN and signed zeros included)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and a.tobytes() == b.tobytes()
