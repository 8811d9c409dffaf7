"""Docks of a world: charging stations, found by name (`dock*`) among its models and spawn points.

World files mark docks as visual-only models (`dock_1`, … in warehouse.world); a spawn-point frame whose
name starts with `dock` counts too.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

from sim.errors import ErrorCode, FleetError, unknown_name
from sim.types import Pose2D, WorldDescription

DOCK_PREFIX = "dock"


def dock_table(description: WorldDescription) -> dict[str, Pose2D]:
    docks = {m.name: Pose2D(m.pose.x, m.pose.y, m.pose.yaw) for m in description.models
             if m.name.lower().startswith(DOCK_PREFIX)}
    for sp in description.spawn_points:
        if sp.name.lower().startswith(DOCK_PREFIX):
            docks.setdefault(sp.name, sp.pose)
    return docks


def check_dock(docks: Mapping[str, Pose2D], name: str | None) -> None:
    """Raise a clear error when the world has no docks, or no dock of that name."""
    if not docks:
        raise FleetError(ErrorCode.NOT_FOUND, "this world has no docks",
                         "add models or frames named dock_* to the world file")
    if name is not None and name not in docks:
        raise unknown_name("dock", name, list(docks), ErrorCode.NOT_FOUND)


def nearest_dock(docks: Mapping[str, Pose2D], x: float, y: float, taken: Iterable[str] = ()) -> str:
    """The dock closest in a straight line, preferring one no other robot is heading to or charging at."""
    check_dock(docks, None)
    busy = set(taken)
    free = [n for n in docks if n not in busy] or list(docks)
    return min(free, key=lambda n: (math.hypot(docks[n].x - x, docks[n].y - y), n))
