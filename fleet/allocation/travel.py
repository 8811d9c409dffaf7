"""Travel costs between locations: straight lines, or shortest paths on a grid around obstacles.

Grid costs: one multi-source Dijkstra (scipy, in C) over the 8-connected free cells of a coarse costmap
(default 0.2 m), from each *source* location; the graph is undirected, so a table row and its column come
from the same search. Only pairs with at least one source end are filled (the allocator asks for no
others). 8-connected lengths are at most 8 % longer than the true shortest path in open space. A point
in an obstacle's inflation snaps to the nearest free cell within `snap` m; farther than that it is
unreachable (inf).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
import shapely
from scipy.ndimage import distance_transform_edt
from scipy.sparse.csgraph import dijkstra
from scipy.spatial.distance import cdist

from planning.global_planners.cost_to_go import grid_graph
from planning.types import Costmap

CHUNK = 64  # sources per Dijkstra call (bounds memory: CHUNK × cells floats)


class TravelTable(Protocol):
    dist: np.ndarray  # (P, P) metres, inf where unreachable

    def path(self, i: int, j: int) -> np.ndarray:
        """(N, 2) polyline from location i to location j."""
        ...


class Travel(Protocol):
    name: str

    def table(self, points: np.ndarray, sources: np.ndarray) -> TravelTable:
        """Distances between `points` (P, 2); rows/columns of `sources` (indices) are complete."""
        ...


class StraightTable:
    def __init__(self, points: np.ndarray) -> None:
        self.points = points
        self.dist = cdist(points, points)

    def path(self, i: int, j: int) -> np.ndarray:
        return self.points[[i, j]]


class EuclideanTravel:
    name = "euclidean"

    def table(self, points: np.ndarray, sources: np.ndarray) -> StraightTable:
        return StraightTable(np.asarray(points, dtype=float).reshape(-1, 2))


class GridTable:
    def __init__(self, travel: GridTravel, points: np.ndarray, sources: np.ndarray) -> None:
        self.travel, self.points = travel, points
        cm = travel.costmap
        self.cells = travel.snap(points)  # flat cell index per point, -1 if unreachable
        offset = np.full(len(points), np.inf)  # from the point to its cell centre
        ok = self.cells >= 0
        offset[ok] = np.hypot(*(travel.centres(self.cells[ok]) - points[ok]).T)
        self.dist = np.full((len(points), len(points)), np.inf)
        src = np.unique(np.asarray(sources, dtype=int))
        src = src[ok[src]]
        self.pred: dict[int, np.ndarray] = {}
        for k in range(0, len(src), CHUNK):
            chunk = src[k:k + CHUNK]
            d, pred = dijkstra(travel.graph, directed=False, indices=self.cells[chunk], return_predecessors=True)
            rows = np.where(ok[None, :], d[:, np.maximum(self.cells, 0)] * cm.resolution, np.inf)
            rows = rows + offset[None, :] + offset[chunk, None]
            self.dist[chunk, :] = rows
            self.dist[:, chunk] = rows.T
            for n, s in enumerate(chunk):
                self.pred[int(s)] = pred[n].astype(np.int32)
        np.fill_diagonal(self.dist, 0.0)

    def path(self, i: int, j: int) -> np.ndarray:
        if not np.isfinite(self.dist[i, j]):
            raise ValueError(f"no path between locations {i} and {j}")
        if j in self.pred:
            cells = self._walk(self.pred[j], self.cells[i])  # i … j
        else:
            cells = self._walk(self.pred[i], self.cells[j])[::-1]
        pts = np.vstack([self.points[i], self.travel.centres(cells), self.points[j]])
        return simplify(pts, self.travel.costmap.resolution / 2)

    @staticmethod
    def _walk(pred: np.ndarray, cell: int) -> np.ndarray:
        out = [int(cell)]
        while pred[out[-1]] >= 0:
            out.append(int(pred[out[-1]]))
        return np.array(out)


class GridTravel:
    name = "path"

    def __init__(self, costmap: Costmap, snap: float = 0.5) -> None:
        self.costmap = costmap
        free = np.asarray(costmap.free_mask, dtype=bool)
        self.shape = free.shape
        self.graph = grid_graph(free)
        # nearest free cell of every cell, and how far it is (cells)
        far, idx = distance_transform_edt(~free, return_indices=True)
        self._near = (idx[0] * free.shape[1] + idx[1]).ravel()
        self._far = far.ravel() * costmap.resolution
        self.snap_m = snap

    def table(self, points: np.ndarray, sources: np.ndarray) -> GridTable:
        return GridTable(self, np.asarray(points, dtype=float).reshape(-1, 2), sources)

    def snap(self, points: np.ndarray) -> np.ndarray:
        h, w = self.shape
        res, (ox, oy) = self.costmap.resolution, self._origin()
        rows = np.floor((points[:, 1] - oy) / res).astype(np.int64)
        cols = np.floor((points[:, 0] - ox) / res).astype(np.int64)
        inside = (rows >= 0) & (rows < h) & (cols >= 0) & (cols < w)
        flat = np.where(inside, rows * w + cols, 0)
        ok = inside & (self._far[flat] <= self.snap_m)
        return np.where(ok, self._near[flat], -1)

    def centres(self, cells: np.ndarray) -> np.ndarray:
        res, (ox, oy) = self.costmap.resolution, self._origin()
        rows, cols = np.divmod(np.asarray(cells, dtype=np.int64), self.shape[1])
        return np.column_stack([ox + (cols + 0.5) * res, oy + (rows + 0.5) * res])

    def _origin(self) -> tuple[float, float]:
        x0, y0, _, _ = self.costmap.bounds
        return (x0, y0)


def simplify(points: np.ndarray, tolerance: float) -> np.ndarray:
    """Douglas–Peucker, keeping the end points."""
    if len(points) <= 2:
        return points
    return np.asarray(shapely.LineString(points).simplify(tolerance).coords)
