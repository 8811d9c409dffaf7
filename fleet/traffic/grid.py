"""The traffic graph: a 4-connected grid of cells on the static map where a robot's footprint fits, with
shared cost-to-go fields (planning/distance_fields.py)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from scipy.sparse import csr_matrix

from fleet.traffic.lanes import DirectedFields, highways
from fleet.traffic.lanes import one_way as one_way_corridors
from planning.distance_fields import DistanceFields
from sim.errors import ErrorCode, FleetError

if TYPE_CHECKING:
    from fleet.avoidance.clearance import StaticClearance


class TrafficGrid:
    """Cells of side `cell` whose centres are at least `radius` + `margin` from every static obstacle; 4-connected
    where the straight segment between centres clears them too."""

    def __init__(self, clearance: StaticClearance, bounds: tuple[float, float, float, float], cell: float,
                 radius: float, margin: float = 0.05, lane_cost: float = 1.0, highway: float = 1.0,
                 one_way: bool = False) -> None:
        if not (math.isfinite(cell) and cell > 0):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"cell must be > 0 m, got {cell}")
        self.cell = cell
        xmin, ymin, xmax, ymax = bounds
        self.origin = (xmin, ymin)
        self.nx, self.ny = int((xmax - xmin) // cell), int((ymax - ymin) // cell)
        ix, iy = np.meshgrid(np.arange(self.nx), np.arange(self.ny), indexing="ij")
        centres = np.column_stack([xmin + (ix.ravel() + 0.5) * cell, ymin + (iy.ravel() + 0.5) * cell])
        free = clearance.query(centres)[0] >= radius + margin
        self.index = np.full(self.nx * self.ny, -1, np.int64)  # grid cell → node, -1 where blocked
        self.index[free] = np.arange(int(free.sum()))
        self.xy = centres[free]  # node → centre
        self.cells = np.flatnonzero(free)
        self.ij = np.column_stack([self.cells // self.ny, self.cells % self.ny])  # node → grid (ix, iy)
        n = len(self.cells)
        rows, cols = [], []
        gx, gy = self.cells // self.ny, self.cells % self.ny
        for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            ok = (gx + dx >= 0) & (gx + dx < self.nx) & (gy + dy >= 0) & (gy + dy < self.ny)
            other = np.where(ok, self.index[np.clip(gx + dx, 0, self.nx - 1) * self.ny
                                            + np.clip(gy + dy, 0, self.ny - 1)], -1)
            keep = other >= 0
            # The straight segment between the centres must clear obstacles too (a shelf corner between them).
            a = self.xy[np.flatnonzero(keep)]
            b = self.xy[other[keep]]
            ts = np.linspace(0.0, 1.0, 11)[1:-1]
            pts = (a[:, None, :] + ts[None, :, None] * (b - a)[:, None, :]).reshape(-1, 2)
            ok_edge = (clearance.query(pts)[0] >= radius + margin).reshape(len(a), -1).all(axis=1)
            keep[np.flatnonzero(keep)[~ok_edge]] = False
            rows.append(np.flatnonzero(keep))
            cols.append(other[keep])
        r, c = np.concatenate(rows), np.concatenate(cols)
        # One-lane cells (two neighbours or fewer) cost `lane_cost` to cross: robots use the wide aisles when
        # that is not much longer, so fewer meet head-on where one of them must back out.
        deg = np.bincount(r, minlength=n)
        cost = np.where(deg <= 2, lane_cost, 1.0)
        self.adjacency = csr_matrix((0.5 * (cost[r] + cost[c]), (r, c)), shape=(n, n))
        # One-way corridors (lanes.py): robots never meet head-on in a one-lane corridor that is not a dead end,
        # where the one pushed back must retreat cell by cell; directions that keep the graph strongly connected.
        self.one_way: list[list[int]] = []
        if one_way:
            self.adjacency, self.one_way = one_way_corridors(self.adjacency, self.ij)
        self.neighbours = self._out(self.adjacency)  # out-neighbours (a directed graph when one-way)
        self.fields: DistanceFields  # DirectedFields is one
        if highway != 1.0 or self.one_way:  # moves against a lane's direction cost `highway` times more (lanes.py)
            self.adjacency = highways(self.adjacency, self.ij, highway)
            self.fields = DirectedFields(self.adjacency)
        else:
            self.fields = DistanceFields(self.adjacency)

    @staticmethod
    def _out(adjacency: csr_matrix) -> list[list[int]]:
        """Per node, the nodes an edge leads to from it."""
        return [adjacency.indices[adjacency.indptr[i]:adjacency.indptr[i + 1]].tolist()
                for i in range(adjacency.shape[0])]

    def __len__(self) -> int:
        return len(self.cells)

    def node_at(self, x: float, y: float) -> int:
        """The node whose cell contains (x, y), or -1 (outside or blocked)."""
        ix, iy = int((x - self.origin[0]) // self.cell), int((y - self.origin[1]) // self.cell)
        if not (0 <= ix < self.nx and 0 <= iy < self.ny):
            return -1
        return int(self.index[ix * self.ny + iy])

    def nodes_at(self, xy: np.ndarray) -> np.ndarray:
        """node_at for many points (n, 2) at once."""
        ix = np.floor((xy[:, 0] - self.origin[0]) / self.cell).astype(np.int64)
        iy = np.floor((xy[:, 1] - self.origin[1]) / self.cell).astype(np.int64)
        ok = (ix >= 0) & (ix < self.nx) & (iy >= 0) & (iy < self.ny)
        return np.where(ok, self.index[np.where(ok, ix * self.ny + iy, 0)], -1)

    def nearest_node(self, x: float, y: float) -> int:
        return int(np.argmin(np.hypot(self.xy[:, 0] - x, self.xy[:, 1] - y)))
