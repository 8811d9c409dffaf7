"""The service's traffic layer: found among the control loop's sources, or enabled there (service side).

Tasks reach it through the fleet view (`FleetView.traffic_layer`), not through the service.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from sim.errors import ErrorCode, FleetError

if TYPE_CHECKING:
    from fleet.service import FleetService
    from fleet.traffic.manager import TrafficManager

SETTINGS = ("cell", "speed", "window", "stall_s", "lane_cost", "seed", "priority", "urgent_s", "yield_aside",
            "highway", "congestion", "urgent_rank", "withdraw", "flush_s", "admission",
            "urgent_cells", "one_way", "urgent_window", "keep_clear", "keep_clear_s", "held_clear",
            "hold_ground_s")


def traffic_layer(service: FleetService) -> TrafficManager | None:
    """The service's traffic layer, if one is enabled."""
    from fleet.traffic.manager import TrafficManager

    return next((s for s in service.control.sources if isinstance(s, TrafficManager)), None)


def ensure_traffic(service: FleetService, settings: dict[str, Any]) -> TrafficManager:
    """The service's traffic layer, enabled with `settings` (checked against SETTINGS) when there is none (on
    the sim thread)."""
    tm = traffic_layer(service)
    if tm is not None:
        return tm
    unknown = sorted(set(settings) - set(SETTINGS))
    if unknown:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"unknown traffic setting(s) {', '.join(unknown)}",
                         f"valid: {', '.join(SETTINGS)}")
    return install_traffic(service, **settings)


def install_traffic(service: FleetService, **kwargs: Any) -> TrafficManager:
    """A new traffic layer (TrafficManager arguments), first in the service's control loop (on the sim thread)."""
    from fleet.traffic.manager import TrafficManager

    tm = TrafficManager(service, **kwargs)
    service.control.sources.insert(0, tm)
    return tm
