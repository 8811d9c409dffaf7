"""Covariance of a correlative match from its score surface (Olson 2009, §IV; Karto's
ComputePositionalCovariance / ComputeAngularCovariance).

ICP's information describes the curvature at the optimum it converged to; it cannot see a second peak 2 m
down a corridor that scores almost as well. The score surface of the correlative search can: every pose in
the window whose score is within `delta` of the best is a plausible answer, weighted by how close it comes.
The weighted second moment of those poses about the best one is the match's covariance: a few cm² around a
clean peak, metres² along a corridor whose doors repeat every few metres.

Translations are sampled on a `step` lattice over the search window at the best rotation, rotations at the
best translation (the cross terms are left out, as in Karto). The result is used when it says the match is
ambiguous (largest σ above `min_sigma`): the pose-graph edge then carries little information along the
ambiguous direction, and loop closures can move the scan along it.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import Field

from sim.config import StrictModel
from slam import se2
from slam.csm import MatchGrid, _lookup


class MatchCovarianceConfig(StrictModel):
    enabled: bool = True
    step: float = Field(0.15, gt=0, description="translation lattice of the score surface, m")
    yaw_step: float = Field(0.02, gt=0, description="rotation lattice, rad")
    delta: float = Field(0.05, gt=0, lt=1, description="poses scoring within this of the best are plausible "
                         "(mean hit likelihood)")
    min_sigma: float = Field(0.25, gt=0, description="the surface's covariance is used when its largest σ "
                             "(translation) is above this, m")


def surface_scores(grid: MatchGrid, points: np.ndarray, pose: se2.PoseTuple, offsets: np.ndarray) -> np.ndarray:
    """Mean field value of `points` (sensor frame) at `pose` shifted by each (dx, dy) in `offsets` (world)."""
    w = se2.transform_points(pose, np.asarray(points, dtype=np.float64).reshape(-1, 2))
    # per axis, the same arithmetic as grid.cells on the (k, n, 2) stack; int32 cells take _lookup's fast path
    cx = np.floor((w[None, :, 0] + offsets[:, 0, None] - grid.origin[0]) / grid.resolution)
    cy = np.floor((w[None, :, 1] + offsets[:, 1, None] - grid.origin[1]) / grid.resolution)
    if max(np.abs(cx).max(initial=0.0), np.abs(cy).max(initial=0.0)) < 2 ** 30:
        cx, cy = cx.astype(np.int32), cy.astype(np.int32)
    else:
        cx, cy = cx.astype(np.int64), cy.astype(np.int64)
    return _lookup(grid.field, cx, cy).mean(axis=1)


def _moment(offsets: np.ndarray, scores: np.ndarray, delta: float) -> np.ndarray:
    """Weighted second moment about 0 of the offsets scoring within `delta` of the best."""
    best = float(scores.max())
    w = np.clip(scores - (best - delta), 0.0, None)
    w = w / w.sum()
    return np.einsum("k,ki,kj->ij", w, offsets, offsets)


def translation_surface(grid: MatchGrid, points: np.ndarray, pose: se2.PoseTuple, window_xy: float,
                        step: float) -> tuple[np.ndarray, np.ndarray]:
    """(offsets (k, 2) in the world frame on a `step` lattice over ± window_xy, their scores) at `pose`'s
    rotation."""
    n = max(1, math.floor(window_xy / step))
    g = np.arange(-n, n + 1) * step
    gx, gy = np.meshgrid(g, g, indexing="ij")
    offs = np.column_stack([gx.ravel(), gy.ravel()])
    return offs, surface_scores(grid, np.asarray(points, dtype=np.float64).reshape(-1, 2), pose, offs)


def score_covariance(grid: MatchGrid, points: np.ndarray, pose: se2.PoseTuple, window_xy: float,
                     window_yaw: float, config: MatchCovarianceConfig,
                     surface: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """3×3 covariance (x, y, yaw in the world frame) of the match `pose` from the score surface over the
    window (± window_xy, ± window_yaw around `pose`); `surface`: `translation_surface`'s result, if known."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    offs, scores = surface or translation_surface(grid, pts, pose, window_xy, config.step)
    cov = np.zeros((3, 3))
    cov[:2, :2] = _moment(offs, scores, config.delta)
    m = max(1, math.floor(window_yaw / config.yaw_step))
    yaws = np.arange(-m, m + 1) * config.yaw_step
    c, s = np.cos(pose[2] + yaws), np.sin(pose[2] + yaws)
    wx = c[:, None] * pts[None, :, 0] - s[:, None] * pts[None, :, 1] + pose[0]
    wy = s[:, None] * pts[None, :, 0] + c[:, None] * pts[None, :, 1] + pose[1]
    cells = grid.cells(np.stack([wx, wy], axis=-1))
    ys = _lookup(grid.field, cells[..., 0], cells[..., 1]).mean(axis=1)
    cov[2, 2] = float(_moment(yaws[:, None], ys, config.delta)[0, 0])
    return cov


def ambiguous_covariance(grid: MatchGrid, points: np.ndarray, pose: se2.PoseTuple, window_xy: float,
                         window_yaw: float, config: MatchCovarianceConfig,
                         surface: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray | None:
    """The score-surface covariance in the frame of `pose` (a graph edge's frame) when it shows an ambiguous
    match (largest translation σ > min_sigma), else None."""
    if not config.enabled:
        return None
    cov = score_covariance(grid, points, pose, window_xy, window_yaw, config, surface)
    if math.sqrt(max(float(np.linalg.eigvalsh(cov[:2, :2]).max()), 0.0)) <= config.min_sigma:
        return None
    c, s = math.cos(pose[2]), math.sin(pose[2])
    r = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])  # world → pose frame
    return r @ cov @ r.T
