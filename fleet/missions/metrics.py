"""What a run measures while it runs: trajectories, clearances, collisions, event counts.

The collector listens to the service's published snapshots (once per control tick) and to its event bus;
per tick it does one vectorised distance-transform lookup for all robots (static clearance) and one
pairwise distance matrix (robot gaps), never a per-robot Python loop.
"""

from __future__ import annotations

import math
from collections import Counter
from typing import TYPE_CHECKING

import numpy as np

from fleet.missions.types import RunData
from fleet.types import Event, FleetSnapshot

if TYPE_CHECKING:
    from fleet.service import FleetService


class MetricsCollector:
    def __init__(self, svc: FleetService, data: RunData) -> None:
        self.svc, self.data = svc, data
        self._rows: dict[str, list[tuple[float, float, float, float]]] = {}
        self._counts: Counter[str] = Counter()
        self._unsubscribe = svc.events.subscribe(self._on_event)
        svc.tick_listeners.append(self.on_tick)

    def close(self) -> None:
        self._unsubscribe()
        if self.on_tick in self.svc.tick_listeners:
            self.svc.tick_listeners.remove(self.on_tick)

    def on_tick(self, snap: FleetSnapshot) -> None:
        if not snap.names:
            return
        t = round(snap.time, 6)
        for name, (x, y, yaw) in zip(snap.names, snap.pose.tolist(), strict=True):
            self._rows.setdefault(name, []).append((t, x, y, yaw))
        self._clearances(snap)

    def _clearances(self, snap: FleetSnapshot) -> None:
        xy = snap.pose[:, :2]
        radius = np.array([self.data.radius.get(n, 0.0) for n in snap.names])
        dist, _ = self.svc.static_clearance().query(xy)
        edge = dist - radius
        for name, d in zip(snap.names, edge.tolist(), strict=True):
            if d < self.data.min_static_clearance.get(name, math.inf):
                self.data.min_static_clearance[name] = d
        if len(xy) > 1:
            gaps = np.hypot(*(xy[:, None, :] - xy[None, :, :]).transpose(2, 0, 1)) - radius[:, None] - radius[None, :]
            np.fill_diagonal(gaps, np.inf)
            self.data.min_robot_gap = min(self.data.min_robot_gap, float(gaps.min()))

    def _on_event(self, ev: Event) -> None:
        self._counts[ev.kind] += 1
        if ev.kind == "collision":
            self.data.collisions.append({"t": round(ev.stamp, 6), "robot": ev.robots[0] if ev.robots else "",
                                         "others": list(ev.data.get("others", []))})

    def finish(self) -> None:
        """Freeze the trajectories and counts into the run's data."""
        self.data.traj = {n: np.array(rows, dtype=float).reshape(-1, 4) for n, rows in self._rows.items()}
        self.data.event_counts = dict(sorted(self._counts.items()))
        self.close()
