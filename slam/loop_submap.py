"""A loop-closure submap: scans around an anchor scan, frozen in the anchor's frame (`slam.log_loops`)."""

from __future__ import annotations

import numpy as np

from slam import se2
from slam.csm import MatchGrid, thin
from slam.icp import IcpTarget
from slam.loop_coverage import Coverage


class Submap:
    """Scans around an anchor, in the anchor's frame. The points, match grid and ICP target are built when first
    verified against (many submaps never are)."""

    def __init__(self, anchor: int, scans: list[tuple[se2.PoseTuple, np.ndarray]], descriptor: np.ndarray,
                 resolution: float, sigma: float, margin: float, coverage: bool = False) -> None:
        self.anchor, self.descriptor, self._scans = anchor, descriptor, scans
        self._grid_args = (resolution, sigma, margin)
        self._built: tuple[MatchGrid, IcpTarget] | None = None
        self.coverage = Coverage(np.vstack([se2.transform_points(p, pts[::4]) for p, pts in scans]), 0.25) \
            if coverage else None

    def _build(self) -> tuple[MatchGrid, IcpTarget]:
        if self._built is None:
            res, sigma, margin = self._grid_args
            pts = self._points()
            self._built = (MatchGrid(pts, res, sigma, margin=margin), IcpTarget.from_points(pts))
        return self._built

    def wide_grid(self, window: float) -> MatchGrid:
        """A match grid (not kept) whose zero margin holds a ±`window` search: the branch-and-bound bounds of a
        block that starts off the grid read 0, so a window wider than the margin could prune the best pose."""
        res, sigma, _ = self._grid_args
        return MatchGrid(self._points(), res, sigma, margin=2 * window + 1.0)

    def _points(self) -> np.ndarray:
        """The scans' returns in the anchor's frame, one per half grid cell."""
        return thin(np.vstack([se2.transform_points(p, pts) for p, pts in self._scans]), self._grid_args[0] / 2)

    def release(self) -> None:
        self._built = None

    @property
    def grid(self) -> MatchGrid:
        return self._build()[0]

    @property
    def target(self) -> IcpTarget:
        return self._build()[1]
