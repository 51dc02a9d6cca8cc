"""Scenario files naming a URDF robot (``robot: {urdf: ...}``) and starts given by name.

Uses the small URDF of :mod:`tests.scenario.mini_urdf` (no example-robot-data needed): schema
accepts and rejects, relative and package:// paths, what the resolved scenario records, the
start mapping and its defaults, collision spheres given by hand, a start in self-collision.
"""

from __future__ import annotations

import copy
import os
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from mmplan import Scenario, ScenarioError, load_scenario
from mmplan.scenario.robot_entry import PACKAGE_PATH_ENV
from tests.eta_planner import METHOD
from tests.scenario.mini_urdf import mini_entry, write_mini

pytest.importorskip("pinocchio", reason="URDF robots need Pinocchio (pip install 'mmplan[urdf]')")


def scenario(robot: Any, **changes: Any) -> dict[str, Any]:
    data: dict[str, Any] = {
        "name": "urdf", "robot": robot,
        "start": {"joint1": 0.3},
        "goal": {"position": [1.0, 0.0, 0.6], "tolerance": 0.01},
        "planner": {"method": METHOD, "eta": [0.1, 0.1, 0.0, 0.0]},
    }
    data.update(changes)
    return data


def write_scenario(path: Path, data: dict[str, Any]) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.fixture(scope="module")
def robots_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder holding ``robots/mini.urdf`` (and a package ``mini_description``)."""
    root = tmp_path_factory.mktemp("urdf")
    write_mini(root / "robots")
    write_mini(root / "packages" / "mini_description" / "urdf")
    return root


def test_relative_urdf_path_is_relative_to_the_scenario_file(
        robots_dir: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = write_scenario(robots_dir / "scenarios" / "s.yaml",
                          scenario(mini_entry("../robots/mini.urdf")))
    monkeypatch.chdir(robots_dir / "packages")  # not the scenario's folder
    sc = load_scenario(path)
    robot = sc.robot
    assert robot.name == "mini"
    assert robot.coordinates == ("x", "y", "theta", "wheel_left_joint", "wheel_right_joint",
                                 "joint1", "joint2")
    assert robot.source.held["head_joint"] == 0.5  # type: ignore[attr-defined]
    # the resolved scenario records the URDF by its absolute path and reloads from anywhere
    entry = sc.resolved_dict()["robot"]
    assert entry["urdf"] == str((robots_dir / "robots" / "mini.urdf").resolve())
    assert entry["locked"] == {"head_joint": 0.5} and entry["collision"]["tolerance"] == 0.02
    again = Scenario.from_dict(yaml.safe_load(sc.to_yaml()), base_dir=Path("/"))
    assert again.robot.coordinates == robot.coordinates
    assert again.robot.collision == robot.collision
    np.testing.assert_array_equal(again.start, sc.start)


def test_missing_relative_file_names_the_key_and_the_folder(robots_dir: Path) -> None:
    path = write_scenario(robots_dir / "scenarios" / "missing.yaml",
                          scenario(mini_entry("robots/mini.urdf")))  # one level too deep
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert info.value.field == "robot.urdf"
    assert "no such file" in info.value.problem
    assert f"relative to {(robots_dir / 'scenarios').resolve()}" in info.value.problem


def test_package_uri_resolved_through_the_environment_variable(
        robots_dir: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    uri = "package://mini_description/urdf/mini.urdf"
    monkeypatch.setenv(PACKAGE_PATH_ENV, os.pathsep.join(["/nonexistent",
                                                          str(robots_dir / "packages")]))
    sc = Scenario.from_dict(scenario(mini_entry(uri)))
    assert sc.robot.name == "mini"
    assert sc.resolved_dict()["robot"]["urdf"] == uri  # kept as written: portable
    monkeypatch.setenv(PACKAGE_PATH_ENV, "/nonexistent")
    with pytest.raises(ScenarioError) as info:
        Scenario.from_dict(scenario(mini_entry(uri)))
    assert info.value.field == "robot.urdf"
    assert "mini_description/urdf/mini.urdf not found" in info.value.problem


def _with(entry: dict[str, Any], key: str, value: Any) -> dict[str, Any]:
    out = copy.deepcopy(entry)
    node = out
    parts = key.split(".")
    for part in parts[:-1]:
        node = node[part]
    node[parts[-1]] = value
    return out


@pytest.mark.parametrize(("key", "value", "field", "problem"), [
    ("platform.wheels", ["wheel_left_joint", "wheel_back_joint"], "robot.platform.wheels[1]",
     "unknown wheel joint 'wheel_back_joint'"),
    ("end_effector", "gripper", "robot.end_effector", "unknown frame 'gripper'"),
    ("locked", {"neck_joint": 0.0}, "robot.locked.neck_joint", "unknown joint 'neck_joint'"),
    ("locked", {"head_joint": 3.0}, "robot.locked.head_joint", "outside the joint's limits"),
    ("platform.kind", "tank", "robot.platform.kind", "'differential-drive'"),
    ("platform.wheel_radius", -0.1, "robot.platform.wheel_radius", "greater than 0"),
    ("mount", {"xyz": [0, 0]}, "robot.mount.xyz", "expected 3 values"),
    ("colour", "red", "robot.colour", "unknown key"),
    ("collision.tolerance", 0.0, "robot.collision.tolerance", "greater than or equal to 0.001"),
    ("collision.spheres", {"gripper": [{"center": [0, 0, 0], "radius": 0.1}]},
     "robot.collision.spheres.gripper", "unknown body 'gripper'"),
    ("collision.spheres", {"link2": [{"center": [0, 0, 0], "radius": -1.0}]},
     "robot.collision.spheres.link2[0].radius", "greater than or equal to 0"),
    ("urdf", "package://nowhere_description/robot.urdf", "robot.urdf", "not found"),
    ("urdf", "<robot name='broken'><link name='a'>", "robot.urdf", "cannot parse URDF"),
])
def test_bad_robot_entries_name_the_key(robots_dir: Path, key: str, value: Any, field: str,
                                        problem: str) -> None:
    entry = _with(mini_entry(str(robots_dir / "robots" / "mini.urdf")), key, value)
    with pytest.raises(ScenarioError) as info:
        Scenario.from_dict(scenario(entry), "bad.yaml")
    assert info.value.field == field, str(info.value)
    assert problem in info.value.problem, str(info.value)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(("robot", "problem"), [
    (7, "expected a built-in robot's name"),
    ({"platform": {"kind": "omnidirectional"}, "end_effector": "tool"},
     "required key missing"),
])
def test_robot_must_be_a_name_or_a_urdf_mapping(robot: Any, problem: str) -> None:
    with pytest.raises(ScenarioError) as info:
        Scenario.from_dict(scenario(robot))
    assert info.value.field.startswith("robot") and problem in info.value.problem


def test_start_mapping_defaults_and_unknown_names(robots_dir: Path) -> None:
    entry = mini_entry(str(robots_dir / "robots" / "mini.urdf"))
    sc = Scenario.from_dict(scenario(entry, start={"x": 1.5, "theta": 0.25, "joint2": -0.5}))
    # missing: platform and wheels 0; joint1 (limits [0.1, 2.5]) at the limit nearest 0
    np.testing.assert_array_equal(sc.start, [1.5, 0, 0.25, 0, 0, 0.1, -0.5])
    assert sc.resolved_dict()["start"] == [1.5, 0, 0.25, 0, 0, 0.1, -0.5]  # list in q order
    with pytest.raises(ScenarioError) as info:
        Scenario.from_dict(scenario(entry, start={"x": 0.0, "elbow": 1.0}))
    assert info.value.field == "start.elbow"
    assert ("unknown coordinate 'elbow' of mini; valid: x, y, theta, wheel_left_joint, "
            "wheel_right_joint, joint1, joint2") in info.value.problem
    with pytest.raises(ScenarioError) as info:
        Scenario.from_dict(scenario(entry, start={"x": float("nan")}))
    assert info.value.field == "start.x" and "finite" in info.value.problem
    with pytest.raises(ScenarioError) as info:  # the mapping's values are checked like a list
        Scenario.from_dict(scenario(entry, start={"joint1": 3.0}))
    assert info.value.field == "start.joint1"
    assert "joint1 = 3 outside the joint limits [0.1, 2.5]" in info.value.problem


def test_start_mapping_for_a_builtin_robot() -> None:
    sc = Scenario.from_dict(scenario("youbot-3r", start={"y": -0.5, "q2": -0.17, "q3": 0.35},
                                     planner={"method": METHOD, "eta": [0.1, 0, 0, 0, 0]}))
    np.testing.assert_array_equal(sc.start, [0, -0.5, 0, 0, 0, 0, -0.17, 0.35])


def test_start_in_self_collision_is_rejected(robots_dir: Path) -> None:
    entry = mini_entry(str(robots_dir / "robots" / "mini.urdf"))
    with pytest.raises(ScenarioError) as info:
        Scenario.from_dict(scenario(entry, start={"joint2": 1.5707963}))
    assert info.value.field == "start"
    assert "self-collision: platform and link2 overlap" in info.value.problem
    Scenario.from_dict(scenario(entry, start={"joint2": 1.5707963}), check_start=False)


def test_collision_spheres_given_by_hand_replace_the_fit(robots_dir: Path) -> None:
    spheres = [{"center": [0.1, 0, 0], "radius": 0.05}, {"center": [0.4, 0, 0], "radius": 0.05}]
    entry = _with(mini_entry(str(robots_dir / "robots" / "mini.urdf")), "collision.spheres",
                  {"link2": spheres})
    sc = Scenario.from_dict(scenario(entry))
    mine = [s for s in sc.robot.collision if s.body == "link2"]
    assert [(s.center, s.radius) for s in mine] == [((0.1, 0, 0), 0.05), ((0.4, 0, 0), 0.05)]
    pairs = sc.robot.self_collision  # type: ignore[attr-defined]
    assert ("platform", "link2") in pairs.body_pairs  # pairs chosen with the new spheres
    assert sc.resolved_dict()["robot"]["collision"]["spheres"] == {"link2": spheres}


def test_no_collision_model(robots_dir: Path) -> None:
    entry = _with(mini_entry(str(robots_dir / "robots" / "mini.urdf")), "collision", None)
    sc = Scenario.from_dict(scenario(entry))
    assert sc.robot.collision == ()
    assert sc.resolved_dict()["robot"]["collision"] is None


def test_schema_platform_kinds_are_the_loaders() -> None:
    from typing import get_args

    from mmplan.robot.urdf import PlatformKind
    from mmplan.scenario.robot_schema import PlatformKindName

    assert set(get_args(PlatformKindName)) == {k.value for k in PlatformKind}
