"""Parking for robots whose goals admission holds (admission.py, `admission: park`): cells off the main flow.

Held robots left where they stand obstruct the others about as much as moving ones do (docs/benchmarks-fleet.md,
helper 17h: 100 robots with goals among 200 idle ones finish 78.5 tasks/min, against 106 alone). So a held robot
drives to a parking cell instead and waits there, pushable like any idle robot, until its goal is admitted.

Parking cells are chosen once per grid, from the grid alone (no per-map list): the cells fewest shortest paths pass
through (`through_flow`, on the layer's own lane fields, from every node to an evenly spread sample of goals), at most
the median, taken greedily in increasing flow with no two of them adjacent, so parked robots never form a wall
and every cell next to a parked robot stays free for passing. On the warehouse these are the cells along the walls
of the wide aisles and every other cell of the rack aisles' rows; the central aisles are never used.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from fleet.traffic.grid import TrafficGrid


def through_flow(grid: TrafficGrid, goals: int = 64) -> np.ndarray:
    """Per node, the mean number of other nodes whose shortest path (steepest descent on the layer's field) to a
    goal passes through it, over `goals` goals spread evenly over the nodes (endpoints not counted)."""
    n = len(grid)
    flow = np.zeros(n)
    sample = np.unique(np.linspace(0, n - 1, min(goals, n)).round().astype(np.int64))
    for g in sample.tolist():
        d = grid.fields.to(g)
        count = np.where(np.isfinite(d), 1.0, 0.0)
        for v in np.argsort(-d, kind="stable").tolist():  # farthest first: a node's count is final when it is sent
            if v == g or not np.isfinite(d[v]):
                continue
            count[min(grid.neighbours[v], key=lambda u: d[u])] += count[v]
        count[g] = 1.0
        flow += count - (count > 0)
    return flow / len(sample)


def parking_cells(grid: TrafficGrid, flow: np.ndarray) -> list[int]:
    """Cells of at most median flow, lowest first, no two adjacent (module doc)."""
    chosen: set[int] = set()
    lanes = {v for chain in getattr(grid, "one_way", []) for v in chain}  # parked in a one-way corridor, it blocks it
    cap = float(np.median(flow)) + 1e-9  # ties with the median are in (sums in a different order)
    for v in np.argsort(flow, kind="stable").tolist():
        if flow[v] > cap:
            break
        if v not in lanes and not any(u in chosen for u in grid.neighbours[v]):
            chosen.add(v)
    return sorted(chosen)


class Parking:
    """The parking cells and which held robot each is kept for."""

    def __init__(self, grid: TrafficGrid) -> None:
        self.cells = np.asarray(parking_cells(grid, through_flow(grid)), np.int64)
        self.xy = grid.xy[self.cells]
        self.owner: dict[str, int] = {}  # robot → index into cells
        self.free = np.ones(len(self.cells), bool)

    def assign(self, robot: str, here_xy: np.ndarray, here: int) -> int:
        """The robot's parking cell: kept once given; else the nearest free one (straight line); `here` when none
        is free."""
        k = self.owner.get(robot)
        if k is None:
            if not self.free.any():
                return here
            d = np.hypot(*(self.xy - here_xy).T)
            k = int(np.argmin(np.where(self.free, d, np.inf)))
            self.owner[robot], self.free[k] = k, False
        return int(self.cells[k])

    def clear(self) -> None:
        self.owner.clear()
        self.free[:] = True

    def release(self, robot: str) -> None:
        k = self.owner.pop(robot, None)
        if k is not None:
            self.free[k] = True
