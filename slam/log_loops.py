"""Loop closure for `LogSlam`: submaps along the path, candidates by pose uncertainty and descriptor,
verification by branch-and-bound correlative matching + ICP, a robust GTSAM factor, and a consistency
check after optimising (a closure still inconsistent with the rest of the graph is removed again).

A submap is the scans within ±`submap_distance` of path around an anchor scan, frozen in the anchor's
frame once the robot has driven past it. The search radius around the current estimate grows with the
path driven since the submap (or since the last accepted closure, whichever is shorter): that is how far
odometry drift can have carried the estimate.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from sim.transforms import se2_between
from slam import se2
from slam.csm import MatchGrid, search
from slam.icp import IcpTarget, icp
from slam.log_config import LoopConfig
from slam.loop_closure import descriptor_distance, ring_descriptor
from slam.pose_graph import Kernel

if TYPE_CHECKING:
    from slam.log_slam import LogSlam


@dataclass(frozen=True, slots=True)
class Submap:
    anchor: int
    grid: MatchGrid  # in the anchor's frame
    target: IcpTarget
    descriptor: np.ndarray


@dataclass(frozen=True, slots=True)
class Closure:
    source: int  # the new scan
    target: int  # the submap's anchor scan
    relative: se2.PoseTuple  # source in target's frame
    score: float  # branch-and-bound score (0 if not matched)
    inliers: float
    rmse: float
    accepted: bool
    reason: str

    def as_dict(self) -> dict[str, object]:
        return {"source": self.source, "target": self.target, "relative": [round(v, 4) for v in self.relative],
                "score": round(self.score, 3), "inliers": round(self.inliers, 3),
                "rmse": round(self.rmse, 4) if math.isfinite(self.rmse) else None,
                "accepted": self.accepted, "reason": self.reason}


class LoopFinder:
    def __init__(self, config: LoopConfig, slam: LogSlam) -> None:
        self.config = config
        self.slam = slam
        self.anchors: list[int] = []
        self.submaps: dict[int, Submap] = {}
        self.history: list[Closure] = []
        self.reasons: Counter[str] = Counter()
        self._last_try = -math.inf
        self._last_closure_path = 0.0
        self._descriptors: dict[int, np.ndarray] = {}
        self._floor = np.diag([config.sigma_floor_xy ** 2, config.sigma_floor_xy ** 2, config.sigma_floor_yaw ** 2])

    @property
    def accepted(self) -> int:
        return sum(c.accepted for c in self.history)

    def descriptor(self, i: int) -> np.ndarray:
        if i not in self._descriptors:
            self._descriptors[i] = ring_descriptor(self.slam.points[i], self.config.descriptor_rings,
                                                   self.slam.config.mapping.max_range)
        return self._descriptors[i]

    def step(self, i: int) -> None:
        c, s = self.config, self.slam
        path = s.path
        if not self.anchors or path[i] - path[self.anchors[-1]] >= c.submap_spacing:
            self.anchors.append(i)
        for a in self.anchors:  # freeze submaps the robot has driven past
            if a not in self.submaps and path[i] - path[a] > c.submap_distance:
                self.submaps[a] = self._build(a)
        if path[i] - self._last_try < c.every_distance or len(s.points[i]) < c.min_points:
            return
        self._last_try = path[i]
        for a, radius in self.candidates(i):
            closure = self.verify(i, a, radius)
            if closure.accepted:
                break

    def _build(self, a: int) -> Submap:
        s, c = self.slam, self.config
        path = np.array(s.path)
        idx = np.nonzero(np.abs(path - path[a]) <= c.submap_distance)[0]
        idx = idx[idx <= len(s.poses) - 1]
        if len(idx) > 40:
            idx = idx[np.linspace(0, len(idx) - 1, 40).astype(int)]
        anchor = s.poses[a]
        pts = np.vstack([se2.transform_points(se2_between(anchor, s.poses[k]), s.points[k]) for k in idx])
        pts = _thin(pts, c.resolution / 2)
        return Submap(a, MatchGrid(pts, c.resolution, c.sigma, margin=c.radius_max + 1.0),
                      IcpTarget.from_points(pts), self.descriptor(a))

    def candidates(self, i: int) -> list[tuple[int, float]]:
        """(anchor, search radius) of frozen submaps near scan i in the estimate, most similar first."""
        c, s = self.config, self.slam
        path = s.path
        here = s.poses[i]
        found: list[tuple[float, int, float]] = []
        for a, sm in self.submaps.items():
            sep = path[i] - path[a]
            if sep < c.min_path_separation + c.submap_distance:
                continue
            drift = min(sep, path[i] - self._last_closure_path + c.submap_distance)
            radius = min(c.radius_max, c.radius_base + c.radius_drift * drift)
            p = s.poses[a]
            d = math.hypot(p[0] - here[0], p[1] - here[1])
            if d > radius + c.submap_distance:
                continue
            desc = float(descriptor_distance(sm.descriptor, self.descriptor(i))[0])
            if desc > c.descriptor_max_distance:
                continue
            found.append((desc + 0.02 * d, a, radius))
        found.sort()
        return [(a, r) for _, a, r in found[: c.max_candidates]]

    def verify(self, i: int, a: int, radius: float) -> Closure:
        c, s = self.config, self.slam
        sm = self.submaps[a]
        guess = se2_between(s.poses[a], s.poses[i])
        pts = s.points[i]
        sub = pts[np.linspace(0, len(pts) - 1, min(len(pts), 120)).astype(int)]
        res = search(sm.grid, sub, guess, window_xy=radius, window_yaw=c.yaw_window, min_score=c.min_score)
        if res is None:
            return self._record(Closure(i, a, guess, 0.0, 0.0, math.inf, False, "no_match_above_min_score"))
        fit = icp(pts, sm.target, res.pose, max_correspondence=2 * c.resolution, inlier_distance=0.1,
                  range_sigma=0.05)
        if not (fit.converged and fit.inlier_ratio >= c.min_inliers and fit.rmse <= c.max_rmse):
            return self._record(Closure(i, a, fit.pose, res.score, fit.inlier_ratio, fit.rmse, False,
                                        "icp_fitness"))
        cov = np.linalg.inv(fit.information + 1e-9 * np.eye(3)) + self._floor
        return self.add(a, i, fit.pose, cov, res.score, fit.inlier_ratio, fit.rmse)

    def add(self, target: int, source: int, relative: se2.PoseTuple, covariance: np.ndarray, score: float = 1.0,
            inliers: float = 1.0, rmse: float = 0.0) -> Closure:
        """Add a closure with the robust kernel, optimise, and remove it again if it stays inconsistent."""
        g = self.slam.graph
        k = g.add_between(target, source, relative, covariance, self.kernel_for(target, source, relative),
                          self.config.kernel_width)
        g.converge(max_steps=20)
        chi2 = g.chi2(k)
        if chi2 > self.config.residual_chi2:
            g.remove(k)
            g.converge(max_steps=20)
            self.slam.refresh_poses()
            return self._record(Closure(source, target, relative, score, inliers, rmse, False,
                                        "inconsistent_after_optimisation"))
        self.slam.refresh_poses()
        self.slam.edges.append((target, source, relative, covariance))
        self._last_closure_path = self.slam.path[source]
        return self._record(Closure(source, target, relative, score, inliers, rmse, True, "accepted"))

    def kernel_for(self, target: int, source: int, relative: se2.PoseTuple) -> Kernel:
        """The configured kernel, or Cauchy for a closure that moves the estimate by more than
        `strong_kernel_beyond`: most closures only tidy up centimetres and Huber lets them, while a large
        correction is either a real loop (the rest of the graph then agrees and Cauchy barely matters) or a
        wrong match that only its own factor supports (Cauchy's weight falls off as 1/r², Huber's as 1/r)."""
        c = self.config
        if c.strong_kernel_beyond is None:
            return c.kernel
        now = se2_between(self.slam.poses[target], self.slam.poses[source])
        off = math.hypot(now[0] - relative[0], now[1] - relative[1])
        return "cauchy" if off > c.strong_kernel_beyond else c.kernel

    def _record(self, closure: Closure) -> Closure:
        self.history.append(closure)
        self.reasons[closure.reason] += 1
        return closure


def _thin(points: np.ndarray, spacing: float) -> np.ndarray:
    cells = np.floor(points / spacing).astype(np.int64)
    _, first = np.unique(cells, axis=0, return_index=True)
    return points[np.sort(first)]
