"""Content keys of the compiled-library disk cache, and the one-line notice."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from mmplan.compile import codegen
from mmplan.compile.fingerprint import robot_fingerprint, source_fingerprint
from mmplan.robot.library import get_robot, youbot_3r


def test_robot_fingerprint_follows_the_model_not_the_object() -> None:
    a, b = get_robot("youbot-3r"), youbot_3r.build()  # another object, the same model
    assert a is not b and robot_fingerprint(a) == robot_fingerprint(b)
    limits = dataclasses.replace(a.limits, joint_max=a.limits.joint_max - 1e-9)
    assert robot_fingerprint(a.with_limits(limits)) != robot_fingerprint(a)
    assert robot_fingerprint(get_robot("youbot-4r")) != robot_fingerprint(a)


def test_source_fingerprint_follows_the_contents(tmp_path: Path) -> None:
    f = tmp_path / "m.py"
    f.write_text("x = 1\n")
    first = source_fingerprint([f])
    assert source_fingerprint([str(f)]) == first
    f.write_text("x = 2\n")
    assert source_fingerprint([f]) != first


def test_notice_is_one_line_once(capsys: pytest.CaptureFixture[str]) -> None:
    message = f"test notice {np.random.default_rng().integers(1 << 30)}"
    codegen.notice(message)
    codegen.notice(message)
    err = capsys.readouterr().err
    assert err == f"mmplan: {message}\n"


def test_robot_fingerprint_sees_every_bit_of_a_limit_and_code_without_a_file() -> None:
    """Joint limits that differ in the last bit are another key (repr rounds them), and a
    robot class defined without a source file (exec, a notebook) is keyed by its serialized
    model instead of its code: a change of such a class's model is another key."""
    a = get_robot("youbot-3r")
    bumped = np.nextafter(a.limits.joint_max, np.inf)
    other = a.with_limits(dataclasses.replace(a.limits, joint_max=bumped))
    assert robot_fingerprint(other) != robot_fingerprint(a)
    scope: dict[str, object] = {}
    exec("from mmplan.robot.robot import Robot\nclass Mine(Robot):\n    pass\n", scope)
    mine = youbot_3r.build()
    mine.__class__ = scope["Mine"]  # type: ignore[assignment]
    from mmplan.compile import fingerprint

    assert fingerprint._model_code(mine) is None
    assert robot_fingerprint(mine) != robot_fingerprint(a)  # the class name differs too
    shifted = youbot_3r.build()
    shifted.__class__ = scope["Mine"]  # type: ignore[assignment]
    shifted.end_effector = dataclasses.replace(shifted.end_effector, offset=(0.35, 0.0, 0.0))
    assert robot_fingerprint(shifted) != robot_fingerprint(mine)


def test_source_fingerprint_sees_a_change_that_keeps_size_and_mtime(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The hash index (fingerprint._content_hash) is keyed by size, mtime, ctime and inode: a
    same-size edit whose mtime is put back (cp -p, tar -x, touch -r) is read again (found by
    review: keyed by size and mtime alone it kept the old hash)."""
    import os
    import time

    from mmplan.compile import fingerprint

    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(fingerprint, "_INDEX", fingerprint._Index())
    f = tmp_path / "m.py"
    f.write_text("x = 1\n")
    st = os.stat(f)
    later = time.time_ns() + 60_000_000_000  # every file counts as settled
    monkeypatch.setattr(fingerprint.time, "time_ns", lambda: later)
    first = source_fingerprint([f])
    assert fingerprint._INDEX.get()  # the entry was kept
    f.write_text("x = 2\n")
    os.utime(f, ns=(st.st_atime_ns, st.st_mtime_ns))  # same size, mtime put back
    assert os.stat(f).st_mtime_ns == st.st_mtime_ns
    assert source_fingerprint([f]) != first


def test_the_hash_index_is_this_trees_and_forgets_files_that_are_gone(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """One index per installed mmplan (a shared one grew with every checkout: 341 entries, 0.4
    ms to parse a process), written without the entries of removed files."""
    import json
    import time

    from mmplan.compile import fingerprint

    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(fingerprint, "_INDEX", fingerprint._Index())
    later = time.time_ns() + 60_000_000_000  # every file counts as settled
    monkeypatch.setattr(fingerprint.time, "time_ns", lambda: later)
    kept, gone = tmp_path / "kept.py", tmp_path / "gone.py"
    kept.write_text("x = 1\n")
    gone.write_text("y = 2\n")
    source_fingerprint([kept, gone])
    (index,) = (tmp_path / "cache").glob("source_hashes_*.json")
    assert index.name == f"source_hashes_{fingerprint._TREE}.json"
    assert set(json.loads(index.read_text())) == {str(kept), str(gone)}
    gone.unlink()
    other = tmp_path / "other.py"
    other.write_text("z = 3\n")
    source_fingerprint([kept, other])  # a new entry: the index is written again
    assert set(json.loads(index.read_text())) == {str(kept), str(other)}
