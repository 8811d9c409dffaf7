"""Fleet traffic management on a known map: PIBT on a grid with shared cost-to-go fields (see manager.py)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from fleet.traffic.grid import TrafficGrid
from fleet.traffic.manager import TrafficManager
from fleet.traffic.pibt import PIBT

if TYPE_CHECKING:
    from fleet.service import FleetService


def enable_traffic(service: FleetService, **settings: Any) -> TrafficManager:
    """Put a traffic layer first in the service's control loop (on the sim thread) and return it."""

    def do() -> TrafficManager:
        tm = TrafficManager(service, **settings)
        service.control.sources.insert(0, tm)
        return tm

    return service.call(do)


__all__ = ["PIBT", "TrafficGrid", "TrafficManager", "enable_traffic"]
