"""Point-cloud processing for lidar scans and depth-camera clouds (2-D or 3-D points, numpy + scipy).

voxel_filter (PCL VoxelGrid: one centroid per occupied voxel), statistical_outlier_removal (PCL SOR: drop
points whose mean k-NN distance is beyond mean + ratio·σ), cluster_obstacles (Euclidean cluster
extraction: connected components of the eps-neighbour graph, the DBSCAN core without noise labels),
sector_minima (the nearest return per angular sector). Ground removal lives in ground.py.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from sim.errors import ErrorCode, FleetError
from sim.perception.types import Obstacle, SectorMinimum
from sim.types import LidarScan


def _points(points: np.ndarray) -> np.ndarray:
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or p.shape[1] not in (2, 3):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"points must be (n, 2) or (n, 3), got {p.shape}",
                         "pass LidarScan.points() or a depth cloud")
    return p[np.all(np.isfinite(p), axis=1)]


def _positive(name: str, value: float) -> None:
    if not (math.isfinite(value) and value > 0):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{name} must be > 0, got {value}", "")


def voxel_filter(points: np.ndarray, voxel: float) -> np.ndarray:
    """One point per occupied voxel of edge `voxel` (the centroid of the points inside it)."""
    _positive("voxel", voxel)
    p = _points(points)
    if len(p) == 0:
        return p
    keys = np.floor(p / voxel).astype(np.int64)
    _, inverse, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    sums = np.zeros((counts.size, p.shape[1]))
    np.add.at(sums, inverse, p)
    return sums / counts[:, None]


def statistical_outlier_removal(points: np.ndarray, k: int = 8, std_ratio: float = 2.0
                                ) -> tuple[np.ndarray, np.ndarray]:
    """(kept points, inlier mask over the finite input points)."""
    _positive("std_ratio", std_ratio)
    if k < 1:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"k must be ≥ 1, got {k}", "")
    p = _points(points)
    if len(p) <= k:
        return p, np.ones(len(p), dtype=bool)
    dist, _ = cKDTree(p).query(p, k=k + 1)  # the first neighbour is the point itself
    mean_d = dist[:, 1:].mean(axis=1)
    keep = mean_d <= mean_d.mean() + std_ratio * mean_d.std()
    return p[keep], keep


def cluster_obstacles(points: np.ndarray, eps: float = 0.15, min_points: int = 3) -> list[Obstacle]:
    """Clusters of points closer than `eps` to a neighbour, with at least `min_points` members,
    largest first. Use eps above the beam spacing at the range of interest (r·Δθ)."""
    _positive("eps", eps)
    p = _points(points)
    if len(p) == 0:
        return []
    pairs = cKDTree(p).query_pairs(eps, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(p), len(p)))
    n, labels = connected_components(graph, directed=False)
    out = []
    for c in range(n):
        members = p[labels == c]
        if len(members) < max(1, min_points):
            continue
        centre = members.mean(axis=0)
        extent = members.max(axis=0) - members.min(axis=0)
        radius = float(np.linalg.norm(members - centre, axis=1).max())
        out.append(Obstacle(tuple(float(v) for v in centre), tuple(float(v) for v in extent),
                            len(members), radius))
    out.sort(key=lambda o: -o.count)
    return out


def sector_minima(scan: LidarScan, sectors: int = 8) -> list[SectorMinimum]:
    """Split the scan's field of view into `sectors` equal sectors (from angle_min, CCW) and report the
    nearest valid return of each with its bearing."""
    if sectors < 1 or sectors > scan.ranges.size:
        raise FleetError(ErrorCode.INVALID_ARGUMENT,
                         f"sectors must be in 1..{scan.ranges.size}, got {sectors}",
                         "use fewer sectors than beams")
    ranges = np.where(np.isfinite(scan.ranges), scan.ranges, np.inf)
    angles = scan.angles()
    fov = scan.angle_increment * scan.ranges.size
    width = fov / sectors
    idx = np.minimum(((angles - scan.angle_min) / width).astype(int), sectors - 1)
    out = []
    for s in range(sectors):
        sel = np.nonzero(idx == s)[0]
        a0 = scan.angle_min + s * width
        if sel.size == 0 or not np.isfinite(ranges[sel]).any():
            out.append(SectorMinimum(s, a0, a0 + width, math.inf, a0 + width / 2))
            continue
        j = sel[int(np.argmin(ranges[sel]))]
        out.append(SectorMinimum(s, a0, a0 + width, float(ranges[j]), float(angles[j])))
    return out
