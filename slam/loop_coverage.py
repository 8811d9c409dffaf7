"""Loop candidates by coverage: which frozen submaps the new scan can see, whatever the heading.

A 180° scanner driving a corridor back the other way sees the walls the old pass saw, but from the other
side of the room, so a range histogram (`slam.loop_closure.ring_descriptor`) differs and the anchor scan can
be far from the new scan while its submap still covers what the new scan sees. Here a candidate is a submap
whose returns lie within the search radius (the pose uncertainty) of enough of the new scan's returns, put
in the submap's frame by the current estimate. Verification then scores only those covered returns, so a
scan that also sees unmapped space is not penalised for it (branch and bound + ICP still decide).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from slam import se2
from slam.csm import MatchGrid
from slam.match_covariance import translation_surface


class Coverage:
    """A submap's returns, thinned to `spacing`, in its anchor's frame."""

    def __init__(self, points: np.ndarray, spacing: float) -> None:
        cells = np.floor(points / spacing).astype(np.int64)
        _, first = np.unique(cells, axis=0, return_index=True)
        self.tree = cKDTree(points[np.sort(first)])

    def covered(self, points: np.ndarray, pose: se2.PoseTuple, radius: float) -> np.ndarray:
        """Mask of `points` (sensor frame, at `pose` in the anchor's frame) within `radius` of the submap."""
        d, _ = self.tree.query(se2.transform_points(pose, points), distance_upper_bound=radius)
        return np.isfinite(d)


def rival(grid: MatchGrid, points: np.ndarray, pose: se2.PoseTuple, radius: float) -> float:
    """Best score of `points` at `pose` shifted by 0.5 … `radius` m (0.15 m lattice, same rotation)."""
    offsets, scores = translation_surface(grid, points, pose, radius, 0.15)
    far = np.hypot(offsets[:, 0], offsets[:, 1]) > 0.5
    return float(scores[far].max()) if far.any() else 0.0
