"""Scenario YAML -> validated, typed `Scenario` (SI units, resolved paths)."""

from pmmw.config.load import apply_overrides, load_scenario, scenario_to_display
from pmmw.config.schema import Scenario

__all__ = ["Scenario", "apply_overrides", "load_scenario", "scenario_to_display"]
