"""Runs in parallel worker processes: the same outcomes as one after the other, progress
passed back, a worker that dies becomes an error run (the others go on)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from mmplan.reproduce import run as repro
from mmplan.reproduce.workers import Report, can_fork, in_workers

pytestmark = pytest.mark.skipif(not can_fork(), reason="worker processes are forked (Linux)")


def _square(x: int, note: Report) -> int:
    note("half", 0.5)
    if x < 0:
        os._exit(1)  # the process dies (a crash, a kill)
    return x * x


def test_each_call_reports_progress_and_its_result() -> None:
    done: dict[int, int] = {}
    notes: list[tuple[int, str, float]] = []
    in_workers(_square, [(1,), (2,), (3,)], 2, lambda *a: notes.append(a),
               lambda i, why: pytest.fail(why), done.__setitem__)
    assert done == {0: 1, 1: 4, 2: 9}
    assert set(notes) <= {(0, "half", 0.5), (1, "half", 0.5), (2, "half", 0.5)}


def test_a_worker_that_dies_fails_its_call_only_and_is_reported() -> None:
    failed: dict[int, str] = {}
    done: dict[int, int] = {}
    in_workers(_square, [(-1,)], 1, lambda *a: None, failed.__setitem__, done.__setitem__)
    assert done == {} and failed[0].startswith("the worker process failed")


def test_parallel_runs_give_the_numbers_of_runs_one_after_the_other(tmp_path: Path) -> None:
    """omni3-impedance and its variant in two workers vs in this process: same statuses,
    same compared numbers; every run finished once; progress ends at the run count."""
    finished: list[str] = []
    calls: list[tuple[str, float, int]] = []
    two = repro.reproduce(tmp_path / "two", ["omni3-impedance"], report=False, jobs=2,
                          finished=lambda r: finished.append(r.spec.name),
                          progress=lambda *a: calls.append(a))
    one = repro.reproduce(tmp_path / "one", ["omni3-impedance"], report=False, jobs=1)
    assert [r.spec.name for r in two.runs] == [r.spec.name for r in one.runs]
    assert sorted(finished) == sorted(r.spec.name for r in one.runs) and len(finished) == 2
    assert [r.status for r in two.runs] == [r.status for r in one.runs] == ["reached"] * 2
    assert [row.ours for row in two.rows] == [row.ours for row in one.rows] and one.rows
    done = [c[1] for c in calls]
    assert done == sorted(done) and calls[-1][1:] == (2.0, 2)


def test_jobs_must_be_a_whole_number_of_at_least_one(tmp_path: Path) -> None:
    for bad in (0, -1, 1.5, True):
        with pytest.raises(repro.InputError, match="--jobs"):
            repro.reproduce(tmp_path, ["car-rtr-free"], report=False, jobs=bad)  # type: ignore[arg-type]


def test_default_jobs_counts_idle_cpus(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(repro.os, "cpu_count", lambda: 8)
    for load, jobs in ((0.0, repro.MAX_JOBS), (5.4, 3), (7.6, 1), (30.0, 1)):
        monkeypatch.setattr(repro.os, "getloadavg", lambda load=load: (load, load, load))
        assert repro.default_jobs() == jobs, load
