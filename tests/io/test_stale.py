"""Temporary directories of killed writers (issue 16): the next write into the same parent
removes them (or puts a plan moved aside back), never a live writer's, never after PID reuse.

Each writer here is a real child process stopped mid-write and killed with SIGKILL.
"""

from __future__ import annotations

import json
import os
import selectors
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from mmplan import write_plan
from tests.io.test_plan_folder import make_result, make_scenario

ROOT = Path(__file__).resolve().parents[2]

#: A writer that stops (prints READY, sleeps) after writing trajectory.csv into its temporary
#: directory ("tmp"), or after moving the previous plan aside ("old").
CHILD = """
import os, sys, time
import numpy as np
from pathlib import Path
import mmplan.io.plan_folder as pf
from tests.io.test_plan_folder import make_result, make_scenario

out, mode, seed = Path(sys.argv[1]), sys.argv[2], int(sys.argv[3])
write_all, replace = pf._write_all, os.replace

def stop(reason):
    print("READY", reason, flush=True)
    time.sleep(120)

def slow_write_all(folder, *args):
    write_all(folder, *args)
    if mode == "tmp":
        (folder / "summary.json").unlink()  # as if killed before summary.json
        stop(folder)

def slow_replace(src, dst, *args, **kwargs):
    replace(src, dst, *args, **kwargs)
    if mode == "old" and ".old-" in str(dst):
        stop(dst)

pf._write_all = slow_write_all
os.replace = slow_replace
scenario = make_scenario()
pf.write_plan(out, make_result(np.random.default_rng(seed)), scenario.build(), scenario)
"""


def start_writer(tmp_path: Path, out: Path, mode: str, seed: int = 1) -> subprocess.Popen[str]:
    """A child writing ``out``, stopped mid-write (returns once it says READY)."""
    script = tmp_path / "writer.py"
    script.write_text(CHILD)
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (env.get("PYTHONPATH"), str(ROOT)) if p)
    proc = subprocess.Popen([sys.executable, str(script), str(out), mode, str(seed)],
                            cwd=ROOT, env=env, stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    with selectors.DefaultSelector() as sel:
        sel.register(proc.stdout, selectors.EVENT_READ)
        deadline = time.monotonic() + 90
        while time.monotonic() < deadline:
            if sel.select(timeout=1.0) and proc.stdout.readline().startswith("READY"):
                return proc
            if proc.poll() is not None:
                break
    proc.kill()
    pytest.fail("the writer never reached the point where it is killed")


def kill9(proc: subprocess.Popen[str]) -> None:
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=30)
    assert proc.returncode == -signal.SIGKILL


def write(out: Path, seed: int = 0) -> None:
    scenario = make_scenario()
    write_plan(out, make_result(np.random.default_rng(seed)), scenario.build(), scenario)


def names(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def test_a_writer_killed_mid_write_leaves_nothing_after_the_next_write(tmp_path: Path) -> None:
    """Before: .plan.tmp-* (with a partial trajectory.csv) stayed forever."""
    parent = tmp_path / "runs"
    parent.mkdir()
    kill9(start_writer(tmp_path, parent / "plan", "tmp"))
    (left,) = [p for p in parent.iterdir() if p.name.startswith(".plan.tmp-")]
    assert "trajectory.csv" in names(left) and "summary.json" not in names(left)
    assert not (parent / "plan").exists()  # the killed run wrote nothing in place
    write(parent / "other")
    assert names(parent) == ["other"]


def test_a_writer_killed_between_its_renames_gets_the_previous_plan_back(
        tmp_path: Path) -> None:
    """Killed after moving the previous plan aside: before, the plan was gone (it sat in a
    .plan.old-* directory that nothing removed, next to the new plan's .plan.tmp-*)."""
    parent = tmp_path / "runs"
    parent.mkdir()
    write(parent / "plan", seed=0)
    before = {n: (parent / "plan" / n).read_bytes() for n in names(parent / "plan")}
    kill9(start_writer(tmp_path, parent / "plan", "old", seed=1))
    assert not (parent / "plan").exists()
    assert sorted(n.split("-")[0] for n in names(parent)) == [".plan.old", ".plan.tmp"]
    write(parent / "other")
    assert names(parent) == ["other", "plan"]
    assert {n: (parent / "plan" / n).read_bytes() for n in names(parent / "plan")} == before


def test_a_live_writers_directory_is_never_removed(tmp_path: Path) -> None:
    parent = tmp_path / "runs"
    parent.mkdir()
    writer = start_writer(tmp_path, parent / "plan", "tmp")
    try:
        write(parent / "other")
        assert any(n.startswith(".plan.tmp-") for n in names(parent))  # still being written
    finally:
        kill9(writer)
    write(parent / "other")
    assert names(parent) == ["other"]


def test_owner_by_pid_and_start_time_and_lock(tmp_path: Path) -> None:
    """A dead PID, or our PID with another start time (a reused PID), is not the owner; a
    directory someone holds the lock of, or of an unknown naming, is left alone."""
    from mmplan.io.stale import owned_temp_dir, release, remove_stale, start_time

    pid, start = os.getpid(), start_time(os.getpid())
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)
    made = {
        "reused": f".a.tmp-{pid}-{start + 1}-abcdefgh",
        "dead": f".b.old-{int(dead.stdout)}-{start}-abcdefgh",
        "mine": f".c.tmp-{pid}-{start}-abcdefgh",
        "legacy": ".d.tmp-abcdefgh",
        "not a dir": f".e.tmp-{int(dead.stdout)}-1-abcdefgh",
    }
    for kind, name in made.items():
        if kind == "not a dir":
            (tmp_path / name).write_text("x")
        else:
            (tmp_path / name).mkdir()
    locked, lock = owned_temp_dir(tmp_path / "f", "tmp")
    os.rename(locked, tmp_path / f".f.tmp-{int(dead.stdout)}-1-abcdefgh")  # dead owner, locked
    try:
        removed = {p.name for p in remove_stale(tmp_path)}
    finally:
        release(lock)
    assert removed == {made["reused"], made["dead"]}
    assert {made["mine"], made["legacy"], made["not a dir"]} <= set(names(tmp_path))
    assert {p.name for p in remove_stale(tmp_path)} == {f".f.tmp-{int(dead.stdout)}-1-abcdefgh"}


def test_temporary_names_fit_a_long_target(tmp_path: Path) -> None:
    out = tmp_path / ("p" * 240)
    write(out)
    assert json.loads((out / "summary.json").read_text())["samples"] == 37
    write(out)  # replaced: the .old- directory name fits too
    assert names(tmp_path) == ["p" * 240]
