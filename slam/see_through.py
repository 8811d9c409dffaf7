"""Free-space consistency of two scans: how many returns of one lie where the other saw through.

A match score counts the returns that land on the map; returns that land in unmapped space and returns that
land in space the map's scans saw to be empty both count zero. The second kind is evidence against the pose:
on Radish orebro step 117 (a scan looking into an unmapped corridor), the wide search's best peak 2.4 m behind
the truth put 12 % of the scan's returns in the local map's free space and 29 % of the map's returns in the
scan's, against 7 % and 10 % at the true pose (which scored 0.40 against the peak's 0.49). Both directions are
checked by projecting one scan's returns into the other's polar frame (a return closer than the other scan's
return on the same bearing, by more than `margin`, was seen through).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from sim.transforms import se2_between
from slam import se2


def seen_through(pose_a: se2.PoseTuple, pts_a: np.ndarray, pose_b: se2.PoseTuple, pts_b: np.ndarray,
                 margin: float = 0.3, max_gap: float = math.radians(2)) -> tuple[int, int]:
    """(returns of b, at pose_b, lying in a's free space; returns of b on a bearing a has a return within
    `max_gap` of). Points are in their sensor frames."""
    if len(pts_a) < 2 or len(pts_b) == 0:
        return 0, 0
    ang_a = np.arctan2(pts_a[:, 1], pts_a[:, 0])
    order = np.argsort(ang_a)
    ang_a, r_a = ang_a[order], np.hypot(pts_a[order, 0], pts_a[order, 1])
    p = se2.transform_points(se2_between(pose_a, pose_b), pts_b)
    ang, r = np.arctan2(p[:, 1], p[:, 0]), np.hypot(p[:, 0], p[:, 1])
    j = np.clip(np.searchsorted(ang_a, ang), 1, len(ang_a) - 1)
    near_hi, near_lo = np.abs(ang_a[j] - ang) <= max_gap, np.abs(ang_a[j - 1] - ang) <= max_gap
    seen = near_hi | near_lo
    # seen through only if every bracketing beam of a within max_gap went past it: at a depth edge or a wall
    # at grazing incidence the range jumps between neighbouring beams, and the nearer beam alone decides wrongly
    reach = np.minimum(np.where(near_hi, r_a[j], np.inf), np.where(near_lo, r_a[j - 1], np.inf))
    return int((seen & (r < reach - margin)).sum()), int(seen.sum())


def inconsistency(pose: se2.PoseTuple, pts: np.ndarray, others: Sequence[tuple[se2.PoseTuple, np.ndarray]],
                  margin: float = 0.3, of_all: bool = False) -> float:
    """Share of the returns (both ways, over every other scan) that one scan saw through (0 … 1): of those on
    a bearing the other scan covers, or (`of_all`) of all of them, so that a pose with little overlap with the
    other scans is not judged on a few returns."""
    bad = total = 0
    for q, other in others:
        for a, b in (seen_through(q, other, pose, pts, margin), seen_through(pose, pts, q, other, margin)):
            bad += a
            total += b
    if of_all:
        total = sum(len(pts) + len(other) for _, other in others)
    return bad / total if total else 0.0
