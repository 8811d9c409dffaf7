"""2D point-to-line ICP (numpy + scipy cKDTree): loop-closure verification and scan-to-map refinement.

Point-to-line converges in a few iterations on structured indoor scans, and its Hessian is the
information matrix of the match: flat along a corridor, stiff across it. That is the noise model the
pose graph gets for a verified loop closure.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from slam import se2
from slam.types import IcpResult


@dataclass(frozen=True, slots=True)
class IcpTarget:
    """A target point set with its KD-tree and unit normals (PCA of each point's neighbourhood)."""

    points: np.ndarray
    normals: np.ndarray
    tree: cKDTree

    @staticmethod
    def from_points(points: np.ndarray, k: int = 6) -> IcpTarget:
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        tree = cKDTree(pts)
        kk = min(k, len(pts))
        _, idx = tree.query(pts, k=kk)
        nb = pts[np.asarray(idx).reshape(len(pts), kk)]
        centred = nb - nb.mean(axis=1, keepdims=True)
        cov = np.einsum("nki,nkj->nij", centred, centred)
        _, vecs = np.linalg.eigh(cov)
        return IcpTarget(pts, vecs[:, :, 0], tree)  # eigenvector of the smallest eigenvalue = normal


def icp(source: np.ndarray, target: IcpTarget, initial: se2.PoseTuple = (0.0, 0.0, 0.0), *,
        max_correspondence: float = 0.3, inlier_distance: float = 0.1, max_iterations: int = 30,
        tolerance: float = 1e-5, range_sigma: float = 0.01, kernel: float = 0.05) -> IcpResult:
    """Align `source` (n, 2) to `target`; the result pose maps source coordinates into the target frame."""
    src = np.asarray(source, dtype=np.float64).reshape(-1, 2)
    pose = np.array(initial, dtype=np.float64)
    converged = False
    it = 0
    prev = np.zeros(3)
    for it in range(1, max_iterations + 1):  # noqa: B007 - the count is reported
        moved = se2.transform_points(tuple(pose), src)
        dist, idx = target.tree.query(moved, distance_upper_bound=max_correspondence)
        ok = np.isfinite(dist)
        if ok.sum() < 3:
            break
        p, q, n = moved[ok], target.points[idx[ok]], target.normals[idx[ok]]
        r = np.einsum("ij,ij->i", n, p - q)
        jac = np.column_stack([n, n[:, 1] * p[:, 0] - n[:, 0] * p[:, 1]])  # d r / d(tx, ty, θ)
        w = 1.0 / (1.0 + (r / kernel) ** 2)  # Cauchy weights: corners and clutter do not drag the fit
        h = (jac * w[:, None]).T @ jac + 1e-9 * np.eye(3)
        delta = -np.linalg.solve(h, (jac * w[:, None]).T @ r)
        # A correspondence flipping back and forth makes the same tiny step, reversed, every time (a
        # 2-cycle): take half a step (the middle of the cycle) and stop.
        cycling = np.abs(delta).max() < 1e-3 and np.abs(delta + prev).max() < 0.1 * np.abs(delta).max()
        if cycling:
            delta = 0.5 * delta
        # Left-multiply the increment: rotate about the target origin, then translate.
        pose = np.array(se2.from_matrix(se2.to_matrix(tuple(delta)) @ se2.to_matrix(tuple(pose))))
        if cycling or np.abs(delta).max() < tolerance:
            converged = True
            break
        prev = delta
    return _score(src, target, tuple(pose), inlier_distance, range_sigma, it, converged)


def _score(src: np.ndarray, target: IcpTarget, pose: se2.PoseTuple, inlier_distance: float,
           range_sigma: float, iterations: int, converged: bool) -> IcpResult:
    moved = se2.transform_points(pose, src)
    dist, idx = target.tree.query(moved, distance_upper_bound=inlier_distance)
    ok = np.isfinite(dist)
    if ok.sum() < 3:
        return IcpResult(pose, math.inf, float(ok.mean()) if len(ok) else 0.0, iterations, False, np.zeros((3, 3)))
    p, q, n = moved[ok], target.points[idx[ok]], target.normals[idx[ok]]
    r = np.einsum("ij,ij->i", n, p - q)
    jac = np.column_stack([n, n[:, 1] * p[:, 0] - n[:, 0] * p[:, 1]])
    info_left = jac.T @ jac / range_sigma**2
    # The graph perturbs poses on the right (T·exp(ξ)); the Jacobian above perturbs on the left.
    ad = se2.adjoint(pose)
    return IcpResult(pose=pose, rmse=float(np.sqrt(np.mean(r**2))), inlier_ratio=float(ok.mean()),
                     iterations=iterations, converged=converged, information=ad.T @ info_left @ ad)
