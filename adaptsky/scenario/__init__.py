"""Scenario files: Pydantic models, TOML loading and writing."""

from adaptsky.scenario.loading import load_scenario, parse_scenario
from adaptsky.scenario.models import Scenario

__all__ = ["Scenario", "load_scenario", "parse_scenario"]
