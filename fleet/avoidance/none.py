"""`none`: robots do not avoid each other (the baseline the benchmark compares ORCA against)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from fleet.avoidance.registry import Command, register_avoidance
from fleet.avoidance.types import AvoidanceConfig

if TYPE_CHECKING:
    from fleet.fleet_view import FleetView


class NoAvoidanceConfig(AvoidanceConfig):
    type: str = "none"


@register_avoidance("none", NoAvoidanceConfig)
class NoAvoidance:
    """The null object: the control loop calls it like any filter and gets the commands back unchanged."""

    name = "none"

    def filter(self, view: FleetView, desired: dict[str, Command]) -> dict[str, Command]:
        return desired

    def settings(self) -> dict[str, Any]:
        return {"type": self.name}
