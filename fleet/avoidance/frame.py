"""Read the fleet's state for a filter from the fleet view's arrays (no per-robot world calls)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from fleet.avoidance.types import FleetFrame

if TYPE_CHECKING:
    from fleet.fleet_view import FleetView

Command = tuple[float, float]
PASSIVE_OWNERS = ("idle", "manual")


def fleet_frame(view: FleetView, desired: dict[str, Command]) -> FleetFrame:
    """Every robot of the world, with its desired command (zero when none) and whether autonomy drives it.

    Passive robots (idle, manual, e-stopped) keep their command; the others take full responsibility for
    avoiding them instead of half. Robots of one swarm behaviour that keeps its robots apart itself (rendezvous,
    formation, coverage) share a group and are not made to avoid each other, only everyone else."""
    r = view.robots
    names = list(r.names)
    cmd = np.array([desired.get(n, (0.0, 0.0)) for n in names], dtype=float).reshape(-1, 2)
    active = np.array([view.owner(n) not in PASSIVE_OWNERS and not view.estopped(n) for n in names], dtype=bool)
    group = np.array([view.avoidance_group(n) for n in names], dtype=np.int64)
    return FleetFrame(names=names, xy=r.xy, yaw=r.yaw.copy(), v=r.v.copy(), w=r.w.copy(), radius=r.radius.copy(),
                      max_v=r.max_v.copy(), max_w=r.max_w.copy(), cmd=cmd, active=active, group=group)
