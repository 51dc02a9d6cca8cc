"""Scenario files: the schema, parsing with one-line errors, loading, built-in scenarios;
robots named by URDF (:mod:`.robot_entry`), starts by name (:mod:`.start`), and the scenario of
a problem built in Python (:mod:`.from_problem`)."""

from mmplan.scenario.from_problem import scenario_from_problem
from mmplan.scenario.loader import (
    Scenario,
    ScenarioError,
    builtin_scenarios,
    load_scenario,
    scenario_header,
)

__all__ = [
    "Scenario",
    "ScenarioError",
    "builtin_scenarios",
    "load_scenario",
    "scenario_from_problem",
    "scenario_header",
]
