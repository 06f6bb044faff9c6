"""Scenario YAML -> validated, typed `ScenarioConfig` (SI units, resolved paths)."""

from pmmw.config.load import apply_overrides, load_scenario, scenario_to_display
from pmmw.config.schema import ScenarioConfig

__all__ = ["ScenarioConfig", "apply_overrides", "load_scenario", "scenario_to_display"]
