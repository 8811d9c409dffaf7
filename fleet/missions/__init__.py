"""fleet.missions: batch missions from YAML — schema, loader, runner, assertions, reports.

Importing the package registers the built-in assertions and scripted events (see registry.py)."""

from fleet.missions.assertions import ASSERTIONS
from fleet.missions.events import EVENTS
from fleet.missions.loader import load_mission, mission_from_text, validate_files
from fleet.missions.schema import Mission, json_schema, write_json_schema
from fleet.missions.types import AssertionResult, PoseSpec, RunData, RunOutcome

__all__ = [
    "ASSERTIONS",
    "EVENTS",
    "AssertionResult",
    "Mission",
    "PoseSpec",
    "RunData",
    "RunOutcome",
    "json_schema",
    "load_mission",
    "mission_from_text",
    "validate_files",
    "write_json_schema",
]
