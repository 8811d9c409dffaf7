"""OccupancyGrid: a 2D occupancy array with ROS conventions.

`data[row, col]` holds int8 values as nav_msgs/OccupancyGrid does: -1 unknown, 0 free, 100 occupied
(0..100 in between is an occupancy probability in percent). Row 0 is the bottom row (lowest y) and
`origin` is the map-frame position of the lower-left corner of cell (0, 0), as in map_server YAML.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sim.errors import ErrorCode, FleetError

OCCUPIED: int = 100
FREE_CELL: int = 0
UNKNOWN_CELL: int = -1


@dataclass(slots=True)
class OccupancyGrid:
    data: np.ndarray  # int8 (height, width)
    resolution: float  # m per cell
    origin: tuple[float, float] = (0.0, 0.0)  # lower-left corner of cell (0, 0), map frame, m

    def __post_init__(self) -> None:
        if not (math.isfinite(self.resolution) and self.resolution > 0):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"grid resolution must be > 0, got {self.resolution}",
                             "use e.g. 0.05 m")
        if self.data.ndim != 2 or self.data.size == 0:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"grid data must be a non-empty 2D array, "
                             f"got shape {self.data.shape}", "pass a (height, width) array")
        self.data = np.ascontiguousarray(self.data, dtype=np.int8)
        self.origin = (float(self.origin[0]), float(self.origin[1]))

    @classmethod
    def empty(cls, bounds: tuple[float, float, float, float], resolution: float,
              fill: int = FREE_CELL) -> OccupancyGrid:
        """A grid covering (xmin, ymin, xmax, ymax), origin snapped down to a multiple of resolution."""
        xmin, ymin, xmax, ymax = bounds
        if not (xmax > xmin and ymax > ymin):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"empty grid bounds {bounds}", "need xmax > xmin, ymax > ymin")
        ox = math.floor(xmin / resolution + 1e-9) * resolution
        oy = math.floor(ymin / resolution + 1e-9) * resolution
        w = math.ceil((xmax - ox) / resolution - 1e-9)
        h = math.ceil((ymax - oy) / resolution - 1e-9)
        return cls(np.full((h, w), fill, dtype=np.int8), resolution, (ox, oy))

    @property
    def height(self) -> int:
        return int(self.data.shape[0])

    @property
    def width(self) -> int:
        return int(self.data.shape[1])

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        ox, oy = self.origin
        return (ox, oy, ox + self.width * self.resolution, oy + self.height * self.resolution)

    def copy(self) -> OccupancyGrid:
        return OccupancyGrid(self.data.copy(), self.resolution, self.origin)

    # ---- world <-> cell -------------------------------------------------------------------------------

    def world_to_cell(self, x: float, y: float) -> tuple[int, int]:
        """(row, col) of the cell holding (x, y); may be outside the grid (check `in_bounds`)."""
        return (math.floor((y - self.origin[1]) / self.resolution),
                math.floor((x - self.origin[0]) / self.resolution))

    def world_to_cells(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Vectorised world_to_cell over (n, 2) points → (rows, cols) int64 arrays."""
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        rows = np.floor((xy[:, 1] - self.origin[1]) / self.resolution).astype(np.int64)
        cols = np.floor((xy[:, 0] - self.origin[0]) / self.resolution).astype(np.int64)
        return rows, cols

    def cell_to_world(self, row: int, col: int) -> tuple[float, float]:
        """Centre of cell (row, col)."""
        return (self.origin[0] + (col + 0.5) * self.resolution, self.origin[1] + (row + 0.5) * self.resolution)

    def cells_to_world(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Centres of cells → (n, 2)."""
        return np.column_stack([self.origin[0] + (np.asarray(cols) + 0.5) * self.resolution,
                                self.origin[1] + (np.asarray(rows) + 0.5) * self.resolution])

    def in_bounds(self, row: int, col: int) -> bool:
        return 0 <= row < self.height and 0 <= col < self.width

    def in_bounds_many(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        return (rows >= 0) & (rows < self.height) & (cols >= 0) & (cols < self.width)

    def cell_centres(self) -> tuple[np.ndarray, np.ndarray]:
        """(X, Y) arrays of every cell centre, each (height, width)."""
        xs = self.origin[0] + (np.arange(self.width) + 0.5) * self.resolution
        ys = self.origin[1] + (np.arange(self.height) + 0.5) * self.resolution
        return np.meshgrid(xs, ys)

    # ---- masks ----------------------------------------------------------------------------------------

    def occupied(self, threshold: int = 65) -> np.ndarray:
        """Cells at or above `threshold` percent (map_server's default occupied_thresh is 0.65)."""
        return self.data >= threshold

    def unknown(self) -> np.ndarray:
        return self.data < 0

    def free(self, threshold: int = 65) -> np.ndarray:
        return (self.data >= 0) & (self.data < threshold)
