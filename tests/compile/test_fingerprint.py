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
