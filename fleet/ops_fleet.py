"""FleetService operations for formations, fleet commands, swarm behaviours, avoidance and deadlocks."""

from __future__ import annotations

from fleet.core import ServiceCore


class FleetOps(ServiceCore):
    """Mixed into FleetService."""

    def _init_fleet_ops(self) -> None:
        """Called from FleetService._build after the control loop exists (register behaviours, avoidance)."""
