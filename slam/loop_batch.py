"""Bounded per-scan work for `slam.log_loops` on long logs (13k–17k scans, kilometres of path, every place
visited several times).

- Deferred closures. Adding a loop closure to iSAM2 re-eliminates the Bayes tree from the closure's older pose
  to the newest one: a closure back to the first pass costs O(nodes since then), and a long log that revisits
  its map closes a loop every `every_distance` of path. Measured on Radish freiburg-079 played 3× (14.4k
  scans): iSAM2 grew from 0.1 to 19 ms/scan. A closure the current estimate already satisfies (χ² at the
  estimate ≤ `defer_chi2`) has nothing to correct now, so it is queued, accepted, and optimised together with
  the next closure that does need optimising, or after `defer_distance` of path: one re-elimination for a
  batch. Its consistency check (`residual_chi2`) runs then.
- Frozen submaps' match grids are kept for the `max_built` most recently verified ones (a grid is ~0.3–1 MB;
  every submap a long log revisits would otherwise keep one: 2 GB at 14k scans).
- Submap anchors: the estimate's anchor positions as an array, so candidate gating is one vector operation.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Mapping
from typing import Protocol

import numpy as np

from sim.transforms import se2_between
from slam import se2


class Releasable(Protocol):
    def release(self) -> None: ...


def chi2_at(poses: list[se2.PoseTuple], target: int, source: int, relative: se2.PoseTuple,
            covariance: np.ndarray) -> float:
    """Squared Mahalanobis distance of a closure (source in target's frame) at the current estimate."""
    now = se2_between(poses[target], poses[source])
    r = np.array(se2_between(relative, now))
    r[2] = math.remainder(float(r[2]), math.tau)
    return float(r @ np.linalg.solve(covariance, r))


class BuiltCache:
    """The most recently used submaps keep their built grids; older ones release them (rebuilt on demand)."""

    def __init__(self, max_built: int) -> None:
        self.max_built = max_built
        self._lru: OrderedDict[int, Releasable] = OrderedDict()

    def touch(self, key: int, item: Releasable) -> None:
        self._lru[key] = item
        self._lru.move_to_end(key)
        while len(self._lru) > self.max_built:
            _, old = self._lru.popitem(last=False)
            old.release()


def within(anchor_xy: np.ndarray, here: se2.PoseTuple, reach: np.ndarray | float) -> np.ndarray:
    """Mask of anchors (k, 2) within `reach` (per anchor or one value) of `here`."""
    if len(anchor_xy) == 0:
        return np.zeros(0, dtype=bool)
    return np.hypot(anchor_xy[:, 0] - here[0], anchor_xy[:, 1] - here[1]) <= reach


class AnchorTable:
    """(anchors, their path, their (x, y) in the estimate) of the frozen submaps, kept until the estimate is
    replaced (`LogSlam.refresh_poses` swaps its pose list) and extended as submaps freeze (in anchor order)."""

    def __init__(self) -> None:
        self._poses: object = None
        self._n = 0
        self._path = np.zeros(0)
        self._xy = np.zeros((0, 2))

    def get(self, submaps: Mapping[int, object], poses: list[se2.PoseTuple], path: list[float]
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        keys = list(submaps)
        if self._poses is not poses or self._n > len(keys):
            self._poses, self._n, self._path, self._xy = poses, 0, np.zeros(0), np.zeros((0, 2))
        if self._n < len(keys):
            new = keys[self._n:]
            self._path = np.concatenate([self._path, np.array([path[a] for a in new], dtype=np.float64)])
            self._xy = np.vstack([self._xy, np.array([poses[a][:2] for a in new], dtype=np.float64)])
            self._n = len(keys)
        return np.array(keys, dtype=np.int64), self._path, self._xy
