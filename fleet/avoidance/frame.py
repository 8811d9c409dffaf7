"""Read the fleet's state for a filter from the world table (array slices, no per-robot world calls)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from fleet.avoidance.types import FleetFrame

if TYPE_CHECKING:
    from fleet.service import FleetService

Command = tuple[float, float]
PASSIVE_OWNERS = ("idle", "manual")


def fleet_frame(service: FleetService, desired: dict[str, Command]) -> FleetFrame:
    """Every robot of the world, with its desired command (zero when none) and whether autonomy drives it.

    Passive robots (idle, manual, e-stopped) keep their command; the others take full responsibility for
    avoiding them instead of half. Robots of one swarm behaviour that keeps its robots apart itself (rendezvous,
    formation, coverage) share a group and are not made to avoid each other, only everyone else."""
    t = service.world.table
    f = t.f
    names = list(t.names)
    cmd = np.array([desired.get(n, (0.0, 0.0)) for n in names], dtype=float).reshape(-1, 2)
    active = np.array([service.control.owner(n) not in PASSIVE_OWNERS and not service.safety.is_estopped(n)
                       for n in names], dtype=bool)
    group = np.array([service.behaviours.avoidance_group(n) for n in names], dtype=np.int64)
    return FleetFrame(names=names, xy=np.column_stack([f["x"], f["y"]]), yaw=f["yaw"].copy(), v=f["v"].copy(),
                      w=f["w"].copy(), radius=f["radius"].copy(), max_v=f["max_v"].copy(),
                      max_w=f["max_w"].copy(), cmd=cmd, active=active, group=group)
