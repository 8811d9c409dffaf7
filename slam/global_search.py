"""Sensor-driven pose proposals for a lost filter (the dual proposal of Mixture MCL, Thrun et al. 2001).

Uniform random particles almost never land close enough in both position and heading to win: at 5 m
a 0.1 rad heading error already moves beam ends by 0.5 m. So when augmented MCL says "lost", we score
random free-space positions at every heading step against a deliberately blurred likelihood field and
hand the best few poses to the filter, which then weighs them with the real sensor model.
"""

from __future__ import annotations

import math

import numpy as np

from slam.likelihood_field import LikelihoodField


def scan_proposals(field: LikelihoodField, points: np.ndarray, rng: np.random.Generator, *, positions: int = 1500,
                   yaw_step: float = math.radians(5), beams: int = 30, top: int = 20) -> np.ndarray:
    """The `top` best (x, y, yaw) of `positions` random free-space positions × all heading steps."""
    free = field.free_cells
    if len(free) == 0 or len(points) == 0:
        return np.zeros((0, 3))
    xy = free[rng.integers(0, len(free), positions)]
    pts = points[np.linspace(0, len(points) - 1, min(beams, len(points))).astype(int)]
    yaws = np.arange(-math.pi, math.pi, yaw_step)
    c, s = np.cos(yaws), np.sin(yaws)
    # Beam ends rotated by every heading once: (yaws, beams, 2); then offset by every position.
    rot = np.stack([c[:, None] * pts[None, :, 0] - s[:, None] * pts[None, :, 1],
                    s[:, None] * pts[None, :, 0] + c[:, None] * pts[None, :, 1]], axis=-1)
    score = np.empty((positions, len(yaws)), dtype=np.float32)
    for k in range(0, positions, 250):  # chunks keep the working set small
        ends = xy[k:k + 250, None, None, :] + rot[None]
        score[k:k + 250] = field.coarse_log_likelihood(ends).sum(axis=-1)
    best = np.argsort(score.ravel())[::-1][:top]
    i, j = np.unravel_index(best, score.shape)
    return np.column_stack([xy[i], yaws[j]])
