"""Fleet traffic management on a known map: PIBT on a grid with shared cost-to-go fields, executed
asynchronously through an action-dependency graph (see manager.py). Doors: `enable_traffic` (Python), the
`traffic_go` task type (MCP, Zenoh, missions), the mission `traffic:` section."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from fleet.traffic.grid import TrafficGrid
from fleet.traffic.layer import ensure_traffic, install_traffic, traffic_layer
from fleet.traffic.manager import TrafficManager
from fleet.traffic.pibt import PIBT
from fleet.traffic.task import TrafficGoTask

if TYPE_CHECKING:
    from fleet.service import FleetService


def enable_traffic(service: FleetService, **settings: Any) -> TrafficManager:
    """Put a traffic layer first in the service's control loop (on the sim thread) and return it."""

    return service.call(lambda: install_traffic(service, **settings))


__all__ = ["PIBT", "TrafficGoTask", "TrafficGrid", "TrafficManager", "enable_traffic", "ensure_traffic",
           "traffic_layer"]
