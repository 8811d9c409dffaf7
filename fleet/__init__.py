"""fleet: the service core — FleetService façade, registry, events, safety envelope, control loop."""

from fleet.config import BatteryConfig, FleetConfig
from fleet.events import EventBus
from fleet.safety import SafetyConfig, SafetyEnvelope
from fleet.service import FleetService
from fleet.types import ErrorCode, Event, FleetError, FleetSnapshot, RobotView, TaskState

__all__ = [
    "BatteryConfig",
    "ErrorCode",
    "Event",
    "EventBus",
    "FleetConfig",
    "FleetError",
    "FleetService",
    "FleetSnapshot",
    "RobotView",
    "SafetyConfig",
    "SafetyEnvelope",
    "TaskState",
]
