"""Scenario YAML -> validated, typed `Scenario` (SI units, resolved paths)."""

from pmmw_cli.config.load import apply_overrides, load_scenario, scenario_to_display
from pmmw_cli.config.schema import Scenario

__all__ = ["Scenario", "apply_overrides", "load_scenario", "scenario_to_display"]
