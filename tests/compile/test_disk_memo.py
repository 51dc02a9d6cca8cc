"""Results about a robot model kept on disk (:mod:`mmplan.compile.disk_memo`)."""

from __future__ import annotations

from pathlib import Path

import pytest

from mmplan.compile import disk_memo
from mmplan.robot.library import get_robot, youbot_3r


def test_value_is_computed_once_per_model_and_found_again_on_disk(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("MMPLAN_CACHE", str(tmp_path))
    disk_memo._SEEN.clear()
    calls: list[int] = []

    def compute() -> tuple[float, float]:
        calls.append(1)
        return (0.1, 1.0 / 3.0)

    def decode(data: list[float]) -> tuple[float, float]:
        return float(data[0]), float(data[1])

    robot = get_robot("youbot-3r")
    args = ("test", 7, compute, list, decode)
    assert disk_memo.remember(robot, __file__, *args) == (0.1, 1.0 / 3.0)
    assert disk_memo.remember(robot, __file__, *args) == (0.1, 1.0 / 3.0)  # memory
    assert len(calls) == 1 and len(list(tmp_path.glob("test_*_7.json"))) == 1
    disk_memo._SEEN.clear()
    same_model = youbot_3r.build()  # another object: found on disk, exactly
    assert disk_memo.remember(same_model, __file__, *args) == (0.1, 1.0 / 3.0)
    assert len(calls) == 1
    # another model, another computing module, or a corrupt file: computed again
    disk_memo.remember(get_robot("youbot-4r"), __file__, *args)
    disk_memo.remember(same_model, disk_memo.__file__, *args)
    assert len(calls) == 3
    disk_memo._SEEN.clear()
    for f in tmp_path.glob("test_*_7.json"):
        f.write_text("{not json")
    assert disk_memo.remember(same_model, __file__, *args) == (0.1, 1.0 / 3.0)
    assert len(calls) == 4
