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

import numpy as np

from slam import se2
from slam.csm import MatchGrid, search
from slam.loop_coverage import rival


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
