"""Scenario files: the schema, parsing with one-line errors, loading, built-in scenarios."""

from mmplan.scenario.loader import (
    Scenario,
    ScenarioError,
    builtin_scenarios,
    load_scenario,
    scenario_header,
)

__all__ = ["Scenario", "ScenarioError", "builtin_scenarios", "load_scenario", "scenario_header"]
