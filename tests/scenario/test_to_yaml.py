"""scenario.yaml text: libyaml's emitter (when PyYAML has it) writes what yaml.safe_dump writes."""

from __future__ import annotations

import yaml

from mmplan.scenario import builtin_scenarios, load_scenario
from mmplan.scenario.loader import Scenario


def test_to_yaml_is_the_text_of_safe_dump_for_every_builtin_scenario() -> None:
    for name in builtin_scenarios():
        scenario = load_scenario(name, require_planner=False)
        text = scenario.to_yaml()
        body = yaml.safe_dump(scenario.resolved_dict(), sort_keys=False, default_flow_style=None)
        assert text.split("\n", 1)[1] == body, name


def test_awkward_values_are_written_as_safe_dump_writes_them() -> None:
    data = {"name": "a: b # 'c' \"d\" é \u2028 \t end " + "x" * 120, "robot": "youbot-3r",
            "start": [0, 0, 0, 0, 0, 0, -0.17, 0.35],
            "goal": {"position": [1e-300, -0.0, 123456.789012345]},
            "planner": {"method": "extended-jacobian"}}
    scenario = Scenario.from_dict(data)
    body = yaml.safe_dump(scenario.resolved_dict(), sort_keys=False, default_flow_style=None)
    assert scenario.to_yaml().split("\n", 1)[1] == body
    assert yaml.safe_load(scenario.to_yaml())["name"] == data["name"]
