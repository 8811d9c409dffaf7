"""Loop closures: propose by proximity + scan descriptor, verify by ICP, gate for consistency, add robustly.

A closure reaches the graph only if (1) its keyframe is near in the current estimate and its ring
histogram is similar, (2) point-to-line ICP fits (low RMSE, most points matched), (3) the measured
relative pose agrees with the estimate within its joint uncertainty (Mahalanobis gate), and (4) after
optimising with a robust kernel it is still consistent with the rest of the graph; otherwise it is
removed again. Every rejection is counted with its reason.
"""

from __future__ import annotations

import math
from collections import Counter

import numpy as np

from slam import se2
from slam.icp import IcpTarget, icp
from slam.pose_graph import Kernel, PoseGraph
from slam.types import Keyframe, LoopClosure


def ring_descriptor(points: np.ndarray, rings: int, max_range: float) -> np.ndarray:
    """Rotation-invariant ring histogram of the returns' ranges, stored as its cumulative distribution.

    Two descriptors are compared by the mean absolute difference of their CDFs: the 1-D earth mover's
    distance in units of max_range. Unlike a bin-by-bin distance it grows smoothly with the distance
    between the two viewpoints, so nearby keyframes stay similar."""
    r = np.hypot(points[:, 0], points[:, 1])
    hist, _ = np.histogram(r, bins=rings, range=(0.0, max_range))
    return np.cumsum(hist) / max(1, hist.sum())


def descriptor_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Earth mover's distance between ring CDFs (rows of `a` against `b`), 0 … 1."""
    return np.abs(np.atleast_2d(a) - b).mean(axis=1)


def log_se2(p: se2.PoseTuple) -> np.ndarray:
    """SE(2) logarithm in gtsam's (x, y, yaw) tangent order (the error a Between factor uses)."""
    x, y, th = p
    if abs(th) < 1e-9:
        return np.array([x, y, th])
    a = math.sin(th) / th
    b = (1.0 - math.cos(th)) / th
    det = a * a + b * b
    return np.array([(a * x + b * y) / det, (-b * x + a * y) / det, th])


class LoopCloser:
    def __init__(self, *, search_radius: float = 4.0, min_separation: int = 15, max_candidates: int = 2,
                 descriptor_max_distance: float = 0.1, icp_max_correspondence: float = 0.3,
                 icp_max_rmse: float = 0.05, icp_min_inlier_ratio: float = 0.75, min_points: int = 60,
                 icp_range_sigma: float = 0.03, sigma_floor_xy: float = 0.01, sigma_floor_yaw: float = 0.002,
                 kernel: Kernel = "cauchy", kernel_width: float = 3.0, gate_chi2: float = 16.27,
                 residual_chi2: float = 16.27) -> None:
        self.search_radius = search_radius
        self.min_separation = min_separation
        self.max_candidates = max_candidates
        self.descriptor_max_distance = descriptor_max_distance
        self.icp_max_correspondence = icp_max_correspondence
        self.icp_max_rmse = icp_max_rmse
        self.icp_min_inlier_ratio = icp_min_inlier_ratio
        self.min_points = min_points
        self.icp_range_sigma = icp_range_sigma
        self.floor = np.diag([sigma_floor_xy**2, sigma_floor_xy**2, sigma_floor_yaw**2])
        self.kernel: Kernel = kernel
        self.kernel_width = kernel_width
        self.gate_chi2 = gate_chi2
        self.residual_chi2 = residual_chi2
        self._targets: dict[int, IcpTarget] = {}
        self.history: list[LoopClosure] = []
        self.rejections: Counter[str] = Counter()

    @property
    def accepted(self) -> int:
        return sum(1 for c in self.history if c.accepted)

    @property
    def rejected(self) -> int:
        return sum(1 for c in self.history if not c.accepted)

    def target(self, kf: Keyframe) -> IcpTarget:
        """The keyframe's scan as an ICP target (built once, reused by every match against it)."""
        if kf.index not in self._targets:
            self._targets[kf.index] = IcpTarget.from_points(kf.points)
        return self._targets[kf.index]

    def candidates(self, new: Keyframe, keyframes: list[Keyframe], poses: np.ndarray) -> list[int]:
        """Older keyframes near the new one in the estimate, with similar descriptors, best first."""
        n = new.index - self.min_separation
        if n <= 0 or len(new.points) < self.min_points:
            return []
        d = np.hypot(poses[:n, 0] - poses[new.index, 0], poses[:n, 1] - poses[new.index, 1])
        near = np.nonzero(d < self.search_radius)[0]
        if near.size == 0:
            return []
        desc = np.array([keyframes[i].descriptor for i in near])
        dist = descriptor_distance(desc, new.descriptor)
        ok = dist < self.descriptor_max_distance
        order = np.argsort(dist[ok] + d[near][ok] / self.search_radius)  # similar and close first
        return [int(i) for i in near[ok][order][: self.max_candidates]]

    def try_close(self, graph: PoseGraph, new: Keyframe, old: Keyframe) -> LoopClosure:
        """Verify new↔old by ICP and, if it fits, add it through the consistency checks."""
        guess = se2.from_matrix(np.linalg.inv(se2.to_matrix(graph.pose(old.index)))
                                @ se2.to_matrix(graph.pose(new.index)))
        res = icp(new.points, self.target(old), guess, max_correspondence=self.icp_max_correspondence,
                  inlier_distance=min(0.1, self.icp_max_correspondence), range_sigma=self.icp_range_sigma)
        if not res.fits(self.icp_max_rmse, self.icp_min_inlier_ratio):
            return self._record(new.index, old.index, res.pose, res.rmse, res.inlier_ratio, "icp_fitness")
        info = res.information + 1e-6 * np.eye(3)
        cov = np.linalg.inv(info) + self.floor
        return self.add(graph, old.index, new.index, res.pose, cov, res.rmse, res.inlier_ratio)

    def add(self, graph: PoseGraph, target: int, source: int, relative: se2.PoseTuple, covariance: np.ndarray,
            rmse: float = 0.0, inlier_ratio: float = 1.0) -> LoopClosure:
        """Gate, add with the robust kernel, optimise, and remove again if still inconsistent."""
        est = se2.from_matrix(np.linalg.inv(se2.to_matrix(graph.pose(target))) @ se2.to_matrix(graph.pose(source)))
        err = log_se2(se2.from_matrix(np.linalg.inv(se2.to_matrix(relative)) @ se2.to_matrix(est)))
        joint = graph.relative_covariance(target, source) + covariance
        if float(err @ np.linalg.solve(joint, err)) > self.gate_chi2:
            return self._record(source, target, relative, rmse, inlier_ratio, "mahalanobis_gate")
        k = graph.add_between(target, source, relative, covariance, self.kernel, self.kernel_width)
        graph.converge()
        if graph.chi2(k) > self.residual_chi2:
            graph.remove(k)
            return self._record(source, target, relative, rmse, inlier_ratio, "inconsistent_after_optimisation")
        return self._record(source, target, relative, rmse, inlier_ratio, "accepted")

    def _record(self, source: int, target: int, rel: se2.PoseTuple, rmse: float, ratio: float,
                reason: str) -> LoopClosure:
        c = LoopClosure(source, target, rel, rmse, ratio, reason == "accepted", reason)
        self.history.append(c)
        if not c.accepted:
            self.rejections[reason] += 1
        return c
