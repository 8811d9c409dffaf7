"""Likelihood-field sensor model (Thrun et al., Probabilistic Robotics §6.4) over an occupancy grid.

The distance from every cell to the nearest occupied cell is computed once (Euclidean distance
transform); a beam end's likelihood is then z_hit·N(d; 0, σ) + z_rand/max_range, looked up per cell.
Unknown and off-map cells count as `max_distance` away, as AMCL does.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.ndimage import distance_transform_edt

from planning.grid import OccupancyGrid


class LikelihoodField:
    def __init__(self, grid: OccupancyGrid, *, sigma_hit: float = 0.1, z_hit: float = 0.9, z_rand: float = 0.1,
                 max_range: float = 10.0, max_distance: float = 1.0) -> None:
        self.grid = grid
        occ = grid.occupied()
        dist = distance_transform_edt(~occ) * grid.resolution if occ.any() else np.full(occ.shape, np.inf)
        dist = np.minimum(dist, max_distance)
        dist[grid.unknown() & ~occ] = max_distance
        self.distance = dist.astype(np.float32)
        p = z_hit * np.exp(-0.5 * (dist / sigma_hit) ** 2) / (sigma_hit * math.sqrt(2 * math.pi))
        p += z_rand / max_range
        self.log_p = np.log(p).astype(np.float32)
        self._log_p_far = float(np.log(z_hit * math.exp(-0.5 * (max_distance / sigma_hit) ** 2)
                                       / (sigma_hit * math.sqrt(2 * math.pi)) + z_rand / max_range))
        self.sigma_hit = sigma_hit
        # A blurred copy (σ = 3× sigma_hit, ≥ 0.3 m) for global search: wide basins, coarse answers.
        wide = max(0.3, 3 * sigma_hit)
        self.log_p_coarse = np.log(np.exp(-0.5 * (dist / wide) ** 2) + 0.05).astype(np.float32)
        self._log_p_coarse_far = float(np.log(math.exp(-0.5 * (max_distance / wide) ** 2) + 0.05))
        free = grid.free() & (dist > 0)
        rows, cols = np.nonzero(free)
        self.free_cells = grid.cells_to_world(rows, cols)  # where random particles may be put

    def _lookup(self, table: np.ndarray, far: float, xy: np.ndarray) -> np.ndarray:
        g = self.grid
        cols = np.floor((xy[..., 0] - g.origin[0]) / g.resolution).astype(np.int64)
        rows = np.floor((xy[..., 1] - g.origin[1]) / g.resolution).astype(np.int64)
        ok = (rows >= 0) & (rows < g.height) & (cols >= 0) & (cols < g.width)
        out = np.full(xy.shape[:-1], far, dtype=np.float32)
        out[ok] = table[rows[ok], cols[ok]]
        return out

    def log_likelihood(self, poses: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Σ log p over beams for each of (m, 3) poses; `points` (k, 2) are beam ends in base_link."""
        c, s = np.cos(poses[:, 2])[:, None], np.sin(poses[:, 2])[:, None]
        wx = poses[:, 0:1] + c * points[None, :, 0] - s * points[None, :, 1]
        wy = poses[:, 1:2] + s * points[None, :, 0] + c * points[None, :, 1]
        return self._lookup(self.log_p, self._log_p_far, np.stack([wx, wy], axis=-1)).sum(axis=1)

    def coarse_log_likelihood(self, xy: np.ndarray) -> np.ndarray:
        """Blurred per-point log-likelihood of map-frame beam ends (..., 2) → (...)."""
        return self._lookup(self.log_p_coarse, self._log_p_coarse_far, xy)

    def distances(self, pose: tuple[float, float, float], points: np.ndarray) -> np.ndarray:
        """Distance from each beam end (placed at `pose`) to the nearest obstacle, m."""
        c, s = math.cos(pose[2]), math.sin(pose[2])
        xy = np.column_stack([pose[0] + c * points[:, 0] - s * points[:, 1],
                              pose[1] + s * points[:, 0] + c * points[:, 1]])
        return self._lookup(self.distance, float(self.distance.max(initial=0.0)), xy)
