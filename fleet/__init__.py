"""fleet: the service core — FleetService façade, registry, events, safety envelope, control loop.

`FleetService` is imported lazily so the agent SDK (fleet.agent) stays light: it needs no planner or physics.
"""

from typing import TYPE_CHECKING, Any

from fleet.config import BatteryConfig, FleetConfig
from fleet.events import EventBus
from fleet.fleet_view import FleetView, RobotArrays
from fleet.safety import SafetyConfig, SafetyEnvelope
from fleet.types import ErrorCode, Event, FleetError, FleetSnapshot, RobotView, TaskState

if TYPE_CHECKING:
    from fleet.service import FleetService


def __getattr__(name: str) -> Any:
    if name == "FleetService":
        from fleet.service import FleetService

        return FleetService
    raise AttributeError(f"module 'fleet' has no attribute {name!r}")


__all__ = [
    "BatteryConfig",
    "ErrorCode",
    "Event",
    "EventBus",
    "FleetConfig",
    "FleetError",
    "FleetService",
    "FleetSnapshot",
    "FleetView",
    "RobotArrays",
    "RobotView",
    "SafetyConfig",
    "SafetyEnvelope",
    "TaskState",
]
