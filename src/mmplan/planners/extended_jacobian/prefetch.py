"""The next compiled chunk, run on a second core while the rollout checks the one it has.

A chunk (:mod:`~mmplan.planners.extended_jacobian.chunks`) is one call of compiled C
(``chunk_steps`` generator steps), then the rollout's checks of its samples in NumPy (finite
values, goal, stall verdict, cond(E) and cond(Jc_R), the sample log). Measured on
youbot3r-obstacles-torque (warm, nothing else running): 13 chunks a plan, 9.6 ms in C and
4.4 ms of checks. Most chunks are accepted whole, and then the next one starts exactly where
the C call left it (the state after its last step, the same parameters). :class:`Speculation`
runs those next calls on a C thread (:mod:`mmplan.compile.threads`) one after the other, as
far as the run may go (a chain: each next input made from the last output by the worker
itself, so it never waits for the rollout between two chunks); the rollout takes a result
when it asks for a chunk with exactly that input (byte for byte), and otherwise ends the
chain and computes the chunk itself. The samples are the same bits either way (the same C
function on the same input); only where the time goes changes. A plan also starts its first
chunks this way as soon as its parameters are packed
(:meth:`~mmplan.planners.extended_jacobian.functions.GeneratorFunctions.guess_chunk`), and
the interpreter, idle while it waits, runs small tasks meanwhile (:func:`while_waiting`).

Measured (``bench/bench_threads.py``: 30 warm plans each way, interleaved, three runs):
guesses on / off 0.84-0.91 of the time with no other process running, but 1.06-1.35 with one
or two busy processes beside (a new thread waits for a time slice), so guesses pause while no
core is idle (:func:`mmplan.compile.threads.idle_core`: the threads ready to run now). With
guesses the rollout takes the time of its C chunks (13 of about 0.75 ms), the checks hidden.

Nothing is started on a machine with one usable core, nor without the compiled thread
helper. One chain is in flight at most, and the compiled function's argument and work
buffers are used by one thread at a time: every call goes through :meth:`Speculation.call`,
which first takes the chain's next result or ends the chain (joining its call in flight),
and a compiled function has one :class:`Speculation` (:func:`speculation_of`). Chains are
ended at the end of a rollout (the time scaling's backward pass wants the worker), before a
fork and at exit. A
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


def speculation_of(native: Any, follow: threads.Follow | None = None) -> Speculation:
    """The one :class:`Speculation` of a compiled function (kept on it: two over the same
    buffers would race); ``follow``: its calls may run ahead (:class:`Speculation`), given
    when it is made."""
    found = getattr(native, "_mmplan_speculation", None)
    if not isinstance(found, Speculation):
        found = Speculation(native, follow=follow)
        native._mmplan_speculation = found
    return found


class Speculation:
    """Calls of one compiled function (:class:`mmplan.compile.codegen.NativeFunction`), with
    guessed calls running ahead on a C thread.

    A guess at x starts the call at x on the worker thread; with ``follow`` (the rule by
    which a call's output gives the next input, :class:`mmplan.compile.threads.Follow`) the
    worker goes on with the next inputs, up to the guess's ``ahead`` further calls, while
    the caller checks the outputs it has (a chain, :class:`mmplan.compile.threads.Chain`):
    the rollout's chunks then follow one another on the worker without waiting for the
    rollout between two of them. A call at an input other than the one expected next ends
    the chain.

    Args:
        native: The compiled function (input ``native.x``, output ``native.y``).
        enabled: Guess at all (default: when the process may use two cores or more). Without
            the compiled thread helper on disk it is built in the background, and no guess
            is made until it is there.
        follow: Run ahead by this rule (None: one guessed call at a time).
    """

    def __init__(
        self, native: Any, enabled: bool | None = None, follow: threads.Follow | None = None
    ) -> None:
        self._native = native
        self._wanted = threads.cores() >= 2 if enabled is None else enabled
        #: Pause while no core is idle (:func:`mmplan.compile.threads.idle_core`); off when
        #: ``enabled`` was given.
        self.follow_load = enabled is None
        self._follow = follow
        depth = threads.CHAIN_DEPTH if follow is not None else 1
        self._X = np.zeros((depth, len(native.x)))
        self._Y = np.zeros((depth, len(native.y)))
        self._job: threads.Chain | None = None
        #: The input of the next call the worker runs or ran (None: no guess in flight).
        self._guess: Array | None = None
        self._next = 0  # its slot
        self._limit = 1
        self._stop = -np.inf
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

    @property
    def pending(self) -> bool:
        """A guessed call is running or its output not yet taken."""
        return self._guess is not None

    def _ready(self) -> bool:
        if self._job is not None:
            return True
        if not self._wanted:
            return False
        if not threads.ready():  # built in the background meanwhile, for later chunks
            threads.prefetch()
            return False
        follow = self._follow or threads.Follow(0, 0, 0, 0, 1, 0)
        try:
            fn, arg, res, iw, w, mem = self._native.signature()
            self._job = threads.Chain(fn, arg, res, iw, w, mem, self._X, self._Y, follow)
        except OSError:  # does not load: no guesses
            self._wanted = False
        return self._job is not None

    def guess(self, x: Array, replace: bool = False, ahead: int = 0,
              stop: float = -np.inf) -> None:  # fmt: skip
        """Start the call at x on a C thread (nothing when disabled or, unless ``replace``,
        when one is in flight; ``replace``: a guess in flight is joined and dropped first);
        with ``follow``, up to ``ahead`` calls after it, ending after a call whose values
        fall below ``stop`` (:class:`mmplan.compile.threads.Follow`)."""
        if replace and self._guess is not None:
            self._settle(None, idle=False)
        if self._guess is not None or not self._ready() or self._job is None:
            return
        if self.follow_load and not threads.idle_core():
            return
        self._X[0] = x
        self._guess = self._X[0].copy()
        self._next = 0
        self._limit = 1 + max(0, min(ahead, len(self._X) - 1)) if self._follow else 1
        self._stop = stop
        if not self._job.start(self._limit, stop):  # the worker was busy: computed here
            self._limit = 1

    def call(self, x: Array) -> Array:
        """The output at x (a copy): the guess's when it was made at exactly this x, else
        computed now (after ending the guesses in flight, whose results are then dropped)."""
        if self._settle(x):
            self.hits += 1
            out: Array = self._Y[self._next - 1].copy()
            return out
        native = self._native
        native.x[:] = x
        out = native().copy()
        return out

    def settle(self) -> None:
        """End the guesses in flight and drop them."""
        self._settle(None)

    def _settle(self, x: Array | None, idle: bool = True) -> bool:
        """Wait for the next guessed call (running :func:`while_waiting`'s tasks first when
        ``idle``); True when it was made at x and succeeded: its output is slot
        ``_next - 1``, and the guess moves on to the chain's next call, if any. Otherwise
        the chain is ended (its call in flight joined)."""
        guess, job, i = self._guess, self._job, self._next
        if guess is None or job is None:
            return False
        try:
            while idle and _IDLE and not job.ready(i):  # only while the guess runs
                task = _IDLE.pop(0)
                with contextlib.suppress(Exception):  # a warm-up: left to whoever needs it
                    task()
            code = job.slot(i)
        except BaseException:  # joined whatever happened: the thread writes into our buffers
            job.stop()
            self._guess = None
            raise
        ok = code == 0 and x is not None and _same(guess, x)
        if ok:
            self._next = i + 1
        if ok and self._continues(i):
            self._guess = self._following(i)
        else:
            job.stop()
            self._guess = None
        self.misses += 0 if ok else 1
        return ok

    def _continues(self, i: int) -> bool:
        """The chain goes on after slot i (the worker's rule, ``mmplan_chain``)."""
        f = self._follow
        if f is None or i + 1 >= self._limit:
            return False
        err = self._Y[i, f.err_at : f.err_at + f.err_step * f.err_count : f.err_step]
        return not (err.size and err.min() < self._stop)  # NaN: min is NaN, not below

    def _following(self, i: int) -> Array:
        """The input of slot i + 1 (as the worker makes it)."""
        f = self._follow
        assert f is not None
        x = self._X[i].copy()
        x[f.dst : f.dst + f.len] = self._Y[i, f.src : f.src + f.len]
        return x


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
