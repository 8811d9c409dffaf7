"""Loop search after blind travel (`LoopConfig.blind_*`).

When the front end cannot match (a laser dropout, a long featureless corridor, an open hall, a log whose scans
see nothing), the estimate rides on the raw odometry and drifts metres and tens of degrees, with no bound
that a path-proportional radius capped at `radius_max` could express. So the search window of such a scan
grows with the *blind* path since its submap (or the last closure): the branch and bound over the submap grid
(`slam.csm.search`) still costs O(log window) levels. A wide window in a building of parallel corridors and
square rooms also holds aliases (the same walls shifted by a corridor's width, or turned by 90°), so a match
found in a widened window must stand out: no pose of the window farther than 0.5 m (same rotation) or
`exclude` (any translation) from it may score above `max_share` of its score.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from slam import se2
from slam.csm import MatchGrid, search
from slam.loop_coverage import rival

if TYPE_CHECKING:
    from slam.log_config import LoopConfig
    from slam.loop_submap import Submap


def widening(c: LoopConfig, blind: Sequence[float], path: Sequence[float], last_closure_path: float, i: int,
             keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Extra search radius (m) and rotation window (rad) for scan i against each anchor in `keys`, from the
    blind path since the anchor or the last closure (whichever is later)."""
    extra, yaw = np.zeros(len(keys)), np.full(len(keys), c.yaw_window)
    since = blind[i] - blind[min(bisect.bisect_left(path, last_closure_path), i)]
    if since <= 0 or not len(keys):  # the usual case: the front end matched every step since
        return extra, yaw
    steps = np.minimum(since, blind[i] - np.array([blind[int(a)] for a in keys]))
    extra = np.minimum(c.blind_radius_max, c.blind_radius_rate * steps)
    return extra, yaw + np.minimum(c.blind_yaw_max, c.blind_yaw_rate * steps)


class WideGrids:
    """Submap grids for widened windows (`Submap.wide_grid`), the last two kept (a scan tries ≤ 2 submaps)."""

    def __init__(self) -> None:
        self._grids: dict[tuple[int, bool, int], MatchGrid] = {}

    def get(self, sm: Submap, radius: float) -> MatchGrid:
        key = (sm.anchor, sm.coverage is not None, math.ceil(radius))
        if key not in self._grids:
            self._grids[key] = sm.wide_grid(math.ceil(radius))
            while len(self._grids) > 2:
                self._grids.pop(next(iter(self._grids)))
        return self._grids[key]


def rotation_rival(grid: MatchGrid, points: np.ndarray, guess: se2.PoseTuple, window_xy: float, window_yaw: float,
                   best_yaw: float, exclude: float, floor: float, max_range_for_step: float) -> float:
    """Best score above `floor` of `points` in the window (±window_xy, ±window_yaw around `guess`) outside
    ±`exclude` of `best_yaw` (0 if none): two branch-and-bound searches, one per side."""
    lo, hi = guess[2] - window_yaw, guess[2] + window_yaw
    best = 0.0
    for a, b in ((lo, best_yaw - exclude), (best_yaw + exclude, hi)):
        if b <= a:
            continue
        res = search(grid, points, (guess[0], guess[1], (a + b) / 2), window_xy=window_xy, window_yaw=(b - a) / 2,
                     max_range_for_step=max_range_for_step, min_score=floor)
        if res is not None:
            best = max(best, res.score)
    return best


def distinct(grid: MatchGrid, points: np.ndarray, guess: se2.PoseTuple, pose: se2.PoseTuple, score: float,
             window_xy: float, window_yaw: float, exclude: float, max_share: float, max_range_for_step: float
             ) -> bool:
    """Whether the match at `pose` (`score`) stands out in its window (module doc)."""
    floor = max_share * score
    if rival(grid, points, pose, window_xy) > floor:
        return False
    return rotation_rival(grid, points, guess, window_xy, window_yaw, pose[2], exclude, floor,
                          max_range_for_step) <= floor
