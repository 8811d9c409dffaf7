"""Parking for robots whose goals admission holds (admission.py, `admission: park`): cells off the main flow.

Held robots left where they stand obstruct the others about as much as moving ones do (docs/benchmarks-fleet.md,
helper 17h: 100 robots with goals among 200 idle ones finish 78.5 tasks/min, against 106 alone). So a held robot
drives to a parking cell instead and waits there, pushable like any idle robot, until its goal is admitted.

Parking cells are chosen once per grid, from the grid alone (no per-map list): the cells fewest shortest paths pass
through (`through_flow`, on the layer's own lane fields, from every node to an evenly spread sample of goals), at most
the median, taken greedily in increasing flow with no two of them adjacent, so parked robots never form a wall
and every cell next to a parked robot stays free for passing. On the warehouse these are the cells along the walls
of the wide aisles, every other cell of the rack aisles' rows, and 12 of the three-wide central aisle's 117 cells.

Which one a held robot gets: among the free parking cells at most PARK_SLACK cells farther (along the lane fields)
than the nearest, the one nearest its held goal. Trips to parking are as much driving as the tasks themselves
(300 robots on the warehouse: 335 trips in 2 minutes, p90 19 cells, when they went to the nearest cell in a
straight line), so a trip that also brings the robot closer to its goal leaves it less to drive when admitted:
+6–7 % tasks/min with the same waits (docs/benchmarks-fleet.md, eleventh landing; without the slack bound, parking
by the goal alone sent robots across the map and the waits over 30 s grew eightfold).
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


PARK_SLACK = 3.0  # cells: how much longer than the nearest a trip to a parking cell nearer the goal may be


class Parking:
    """The parking cells and which held robot each is kept for."""

    def __init__(self, grid: TrafficGrid) -> None:
        self.grid = grid
        self.cells = np.asarray(parking_cells(grid, through_flow(grid)), np.int64)
        self.owner: dict[str, int] = {}  # robot → index into cells
        self.free = np.ones(len(self.cells), bool)
        self._trips: np.ndarray | None = None  # (parking cell, node): distance from the node to the cell

    def kept(self, robot: str) -> int | None:
        """The parking cell already given to the robot, if any."""
        k = self.owner.get(robot)
        return None if k is None else int(self.cells[k])

    def assign(self, robot: str, here: int, to_goal: np.ndarray | None = None) -> int:
        """The robot's parking cell: kept once given; else, among the free ones at most PARK_SLACK cells farther
        from `here` than the nearest, the one nearest the held goal (`to_goal`: its distance field; without it,
        the nearest); `here` when none is free or reachable."""
        k = self.owner.get(robot)
        if k is None:
            if self._trips is None:  # one field per parking cell, once (the lane fields' cache keeps them)
                self._trips = np.stack([self.grid.fields.to(int(c)) for c in self.cells]) if len(self.cells) \
                    else np.zeros((0, len(self.grid)))
            trip = np.where(self.free, self._trips[:, here], np.inf)
            if not np.isfinite(trip.min(initial=np.inf)):
                return here
            cost = trip if to_goal is None else to_goal[self.cells] + 1e-3 * trip  # ties: the shorter trip
            k = int(np.argmin(np.where(trip <= trip.min() + PARK_SLACK, cost, np.inf)))
            self.owner[robot], self.free[k] = k, False
        return int(self.cells[k])

    def clear(self) -> None:
        self.owner.clear()
        self.free[:] = True

    def release(self, robot: str) -> None:
        k = self.owner.pop(robot, None)
        if k is not None:
            self.free[k] = True
