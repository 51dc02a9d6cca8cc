"""Hostile scenario files (issue 16): every one is refused fast with one bounded line (exit 2).

Each case reproduces a defect of the reliability pass: an alias bomb printed its 10^6-value
repr (322 MB) or hung, 1000-deep nesting and a list used as a key ended in RecursionError and
TypeError (exit 1), a 50 MB file was parsed for minutes.
"""

from __future__ import annotations

import re
import time
from pathlib import Path

import pytest
import yaml

from mmplan import ScenarioError, load_scenario
from mmplan.scenario.parse import parse_yaml

# The limits (mmplan.scenario.parse.MAX_FILE_BYTES, safe_yaml.MAX_DEPTH / MAX_NODES), stated
# here so that the tests also run against the code before them (they must fail there).
MAX_FILE_BYTES, MAX_DEPTH, MAX_NODES = 10_000_000, 32, 100_000

HEAD = ("name: hostile\nrobot: youbot-3r\ngoal: {position: [1.0, 0.5, 0.3]}\n"
        "planner: {method: extended-jacobian, t_max: 1}\n")
START = "start: [0, 0, 0, 0, 0, 0, -0.17, 0.35]\n"


def bomb(levels: int, width: int = 10) -> str:
    """``start`` is an alias bomb of ``width ** levels`` numbers (a few hundred bytes)."""
    lines = [f"l0: &l0 [{', '.join(['1.0'] * width)}]"]
    for i in range(1, levels):
        lines.append(f"l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * width)}]")
    return HEAD + "\n".join(lines) + f"\nstart: *l{levels - 1}\n"


def refused(tmp_path: Path, text: str, seconds: float = 5.0) -> str:
    """The one-line message of loading ``text`` as a scenario file, within ``seconds``."""
    path = tmp_path / "s.yaml"
    path.write_text(text)
    began = time.perf_counter()
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert time.perf_counter() - began < seconds
    message = str(info.value)
    assert "\n" not in message and len(message) <= 500, message[:1000]
    assert message.startswith(f"{path}: ")
    return message


def test_alias_bomb_is_refused_fast_without_expanding(tmp_path: Path) -> None:
    """10^9 values in 200 bytes: refused on the event stream, nothing is expanded."""
    message = refused(tmp_path, bomb(9), seconds=2.0)
    assert f"more than {MAX_NODES} values with aliases expanded" in message


def test_small_alias_bomb_message_is_bounded(tmp_path: Path) -> None:
    """10^6 values in start[0]: before, the error printed the whole list (a 3 MB line)."""
    message = refused(tmp_path, bomb(6))
    assert "values with aliases expanded" in message


def test_a_rejected_value_is_shown_cut(tmp_path: Path) -> None:
    """Under the node budget but a huge repr: the value is shown in at most 200 characters."""
    rows = ", ".join(["[" + ", ".join(["1.5"] * 1000) + "]"] * 8)  # 8000 numbers
    message = refused(tmp_path, HEAD + f"start: [{rows}]\n")
    assert "start[0]: input should be a valid number, got [1.5, 1.5" in message
    assert "..." in message
    message = refused(tmp_path, HEAD + f"start: ['{'x' * 2_000_000}']\n")
    assert "start[0]: input should be a valid number, got 'xxx" in message


def test_deep_nesting_is_refused(tmp_path: Path) -> None:
    """1000 nested lists: before, RecursionError (exit 1)."""
    message = refused(tmp_path, HEAD + "start: " + "[" * 1000 + "]" * 1000 + "\n")
    # the path of the refused value: ours at MAX_DEPTH, or where libyaml's own flow-nesting
    # limit (PyYAML >= 6.0.4, C scanner) stops it first
    assert re.search(r": start(\[0\])*: nested", message), message
    assert f"nested more than {MAX_DEPTH} levels deep (line 5, column" in message
    message = refused(tmp_path, HEAD + "start:\n" + "- " * 5000 + "1\n")  # block sequences
    assert f"nested more than {MAX_DEPTH} levels deep" in message


def test_deep_nesting_through_aliases_is_refused(tmp_path: Path) -> None:
    """Each alias adds its anchor's depth: 20 aliases of a 20-deep list nest 400 deep."""
    text = HEAD + "a0: &a0 " + "[" * 20 + "]" * 20 + "\n"
    text += "".join(f"a{i}: &a{i} [*a{i - 1}]\n" for i in range(1, 20)) + "start: *a19\n"
    assert f"nested more than {MAX_DEPTH} levels deep" in refused(tmp_path, text)


@pytest.mark.parametrize(("text", "path", "kind"), [
    ("? [1, 2]\n: 3\n" + START, "", "a sequence used as a mapping key"),
    (START + "goal2: {? {a: 1} : 3}\n", "goal2", "a mapping used as a mapping key"),
    ("k: &k [1]\nobstacles: [{*k : 1}]\n" + START, "obstacles[0]",
     "alias *k of a collection used as a mapping key"),
])
def test_a_collection_as_a_key_is_refused_naming_the_path(tmp_path: Path, text: str, path: str,
                                                          kind: str) -> None:
    """Before: TypeError: unhashable type: 'list' (exit 1)."""
    message = refused(tmp_path, HEAD + text)
    assert message.split(": ", 1)[1].startswith(f"{path}: {kind}" if path else kind), message


def test_recursive_alias_is_refused(tmp_path: Path) -> None:
    message = refused(tmp_path, HEAD + "start: &s [0, 0, *s]\n")
    assert "start[2]: alias *s refers to a collection that contains it" in message


def test_a_file_over_10_mb_is_refused_before_parsing(tmp_path: Path) -> None:
    """Before: parsed (5.8 s per MB) and accepted; now refused from its size alone."""
    text = HEAD + START + "# " + "x" * MAX_FILE_BYTES + "\n"
    message = refused(tmp_path, text, seconds=1.0)
    assert f"file is 10.0 MB ({len(text)} bytes); scenario files are limited to 10 MB" in message


def test_a_large_file_under_the_limit_is_read_fast(tmp_path: Path) -> None:
    """8 MB of comment and a 1 MB name: libyaml's parser reads it in well under a second."""
    path = tmp_path / "big.yaml"
    path.write_text(HEAD.replace("hostile", "h" * 1_000_000) + START + "# " + "x" * 8_000_000)
    began = time.perf_counter()
    scenario = load_scenario(path)
    assert time.perf_counter() - began < 10.0 and len(scenario.name) == 1_000_000


def test_too_many_values_are_refused(tmp_path: Path) -> None:
    text = HEAD + "start: [" + ", ".join(["0.0"] * (MAX_NODES + 10)) + "]\n"
    message = refused(tmp_path, text)
    assert re.search(rf"start\[\d+\]: more than {MAX_NODES} values", message), message


@pytest.mark.parametrize(("text", "expected"), [
    ("start: [" + "9" * 5000 + "]\n", "malformed YAML: Exceeds the limit (4300 digits)"),
    ("start: [" + "9" * 4000 + "]\n", "start[0]: input should be a valid number, got <integer"),
    ("start: [2001-13-45]\n", "malformed YAML: month must be in 1..12"),
    ("start: [0]\n\x00\n", "malformed YAML"),
    ("start: [0]\n---\nb: 1\n", "malformed YAML: line 6, column 1: but found another document"),
    ("start: [0]\nrobot2: *nope\n", "malformed YAML: line 6, column 9: found undefined alias"),
    ("start: [0]\nx1: &x [1]\nx2: &x [2]\n", "malformed YAML: line 7, column 5: found duplicate "
                                            "anchor"),
])
def test_odd_scalars_and_streams_are_one_line(tmp_path: Path, text: str, expected: str) -> None:
    assert expected in refused(tmp_path, HEAD + text)


def test_hostile_keys_and_values_stay_on_one_bounded_line(tmp_path: Path) -> None:
    message = refused(tmp_path, HEAD + START + '? "bad\\nkey' + "k" * 100_000 + '"\n: 1\n')
    assert "'bad\\nkeykkkk" in message and "unknown key" in message
    text = HEAD.replace("youbot-3r", "'" + "r\\n" * 200_000 + "'") + START
    assert "robot: unknown robot" in refused(tmp_path, text)
    text = HEAD + START + "obstacles: [{shape: '" + "s" * 100_000 + "', radius: 1}]\n"
    assert "obstacles[0].shape: unknown shape 'ssss" in refused(tmp_path, text)


def test_merge_keys_work_and_duplicates_are_still_refused() -> None:
    data = parse_yaml("d: &d {radius: 0.1, shape: sphere}\no: [{<<: *d, radius: 0.2}]\n", "s")
    assert data["o"] == [{"radius": 0.2, "shape": "sphere"}]
    with pytest.raises(ScenarioError, match="duplicate key 'radius'"):
        parse_yaml("d: &d {shape: sphere}\no: [{<<: *d, radius: 0.2, radius: 1}]\n", "s")


def test_plain_aliases_under_the_budget_still_load(tmp_path: Path) -> None:
    """Anchors are YAML: a scenario may reuse a vector (the budget counts it twice)."""
    path = tmp_path / "ok.yaml"
    path.write_text(HEAD.replace("[1.0, 0.5, 0.3]", "&p [1.0, 0.5, 0.3]") + START
                    + "obstacles: [{shape: sphere, center: *p, radius: 0.05}]\n")
    scenario = load_scenario(path, check_start=False)
    assert scenario.scene.obstacles[0] is not None


def test_short_repr_never_builds_the_full_repr() -> None:
    from mmplan.scenario.safe_yaml import short_repr

    huge: list[object] = [0.0] * 10
    for _ in range(9):  # 10^10 numbers, shared
        huge = [huge] * 10
    began = time.perf_counter()
    text = short_repr(huge)
    assert time.perf_counter() - began < 0.1 and len(text) <= 200 and "..." in text
    assert short_repr(10 ** 4000) == "<integer of 4001 digits>"
    assert short_repr("a\nb") == "'a\\nb'"
    assert yaml.safe_load("a: 1") == {"a": 1}  # the global loaders are untouched


def test_floats_without_a_dot_are_numbers(tmp_path: Path) -> None:
    """A new user's ``tolerance: 1e-3`` was "not a valid number": PyYAML (YAML 1.1) reads a
    float without a dot as a string. YAML 1.2's form is read as a float; a quoted one stays a
    string, and a huge one is refused by its range."""
    from mmplan.scenario import safe_yaml

    assert safe_yaml.load("a: 1e-3\nb: -2E+5\nc: .5e1\nd: '1e3'\ne: 10") == {
        "a": 0.001, "b": -200000.0, "c": 5.0, "d": "1e3", "e": 10,
    }  # fmt: skip
    text = (Path(__file__).parents[2] / "src/mmplan/scenario/builtin/youbot3r-obstacles.yaml")
    body = text.read_text().replace("tolerance: 0.001", "tolerance: 1e-3")
    assert "tolerance: 1e-3" in body
    path = tmp_path / "sci.yaml"
    path.write_text(body)
    assert load_scenario(path).build().task.tolerance == 0.001
