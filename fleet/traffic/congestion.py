"""Congestion-aware cost-to-go fields: the lane graph plus a toll for entering a cell that has been busy lately.

With 300 robots on warehouse.world the central two-wide aisle fills up, and robots queue at the cells where
rows merge into it, one cell every 16–24 s (docs/benchmarks-fleet.md): the static fields send every robot
whose shortest way crosses the aisle into it, however full it is. Here the cost of entering a cell is raised
by `weight` times its recent occupancy (an exponential moving average over `tau` seconds of "a robot is in or
entering this cell"), so robots with a parallel way of about the same length take it, as congestion-aware
routing does on roads. The fields are recomputed from the current occupancy every `refresh_s` (cached per
goal in between), so a robot's field is fixed while it plans a few steps.

Only the ordering of PIBT's candidates changes; the waits the layer reports are still measured on the static
fields. Off by default (`congestion` 0): at 100 robots on warehouse.world it makes the longest waits longer (robots
on detours do not come closer by the static fields), at 300 it raises throughput by a quarter or more
(docs/benchmarks-fleet.md).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import shortest_path


class CongestionFields:
    def __init__(self, adjacency: csr_matrix, weight: float, tau: float = 20.0, refresh_s: float = 5.0) -> None:
        self.weight, self.tau, self.refresh_s = weight, tau, refresh_s
        self._reverse = csr_matrix(adjacency.T)  # distances *to* a goal = from it over the reversed edges
        n = adjacency.shape[0]
        # A reversed edge v → u stands for the move u → v: its toll is the occupancy of v, its row.
        self._head = np.repeat(np.arange(n), np.diff(self._reverse.indptr))
        self.occupancy = np.zeros(n)
        self._graph = self._reverse
        self._cache: dict[int, np.ndarray] = {}
        self._refreshed = -math.inf
        self.computed = 0

    def observe(self, cells: np.ndarray, dt: float) -> None:
        """Decay the occupancy over dt and add the cells robots are in or entering now."""
        if dt <= 0.0:
            return
        keep = math.exp(-dt / self.tau)
        self.occupancy *= keep
        self.occupancy[np.unique(cells)] += 1.0 - keep

    def refresh(self, now: float) -> None:
        """Rebuild the tolls from the current occupancy every refresh_s (the fields are recomputed lazily)."""
        if now - self._refreshed < self.refresh_s:
            return
        self._refreshed = now
        g = self._reverse.copy()
        g.data = g.data + self.weight * self.occupancy[self._head]
        self._graph = g
        self._cache.clear()

    def to(self, goal: int) -> np.ndarray:
        """Per node, the congestion-weighted cost to reach `goal`."""
        f = self._cache.get(goal)
        if f is None:
            f = self._cache[goal] = shortest_path(self._graph, indices=goal, directed=True)
            self.computed += 1
        return f
