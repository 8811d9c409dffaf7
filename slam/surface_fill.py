"""Fill the gaps between consecutive returns of one scan that lie on the same surface.

A wall seen from far away is a dotted line: 1° beams hit it r·1° apart (17 cm at 10 m), more at a grazing
angle, so its hit-likelihood field (σ ≈ 7 cm) has holes between the dots. Scans later taken close to that wall
then score lower where the map was seen from afar than where it was seen from nearby, which biases a match
in a corridor towards the poses the earlier scans were taken at (measured on Radish orebro: with a local map
built at the reference poses, 13 of 236 steps matched 2–6 m behind; 8 with filled surfaces).

Two consecutive returns (in scan order) are taken to be on one surface when their gap is at most `max_ratio`
times the arc r·Δφ between them (incidence below ~76° for 4) and at most `max_gap`: a depth jump (a door
frame, an object in front of a wall) is much longer than the arc and is left open.
"""

from __future__ import annotations

import numpy as np


def fill_surfaces(points: np.ndarray, step: float = 0.025, max_ratio: float = 4.0, max_gap: float = 1.0
                  ) -> np.ndarray:
    """`points` (n, 2) in the sensor frame, in scan order → the points plus samples every `step` along each
    same-surface gap."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    if len(p) < 2 or max_ratio <= 0:
        return p
    a, b = p[:-1], p[1:]
    d = b - a
    gap = np.hypot(d[:, 0], d[:, 1])
    r = np.minimum(np.hypot(a[:, 0], a[:, 1]), np.hypot(b[:, 0], b[:, 1]))
    dphi = np.abs(np.remainder(np.arctan2(b[:, 1], b[:, 0]) - np.arctan2(a[:, 1], a[:, 0]) + np.pi, 2 * np.pi)
                  - np.pi)
    same = (gap > step) & (gap <= max_gap) & (gap <= max_ratio * np.maximum(r * dphi, 1e-9))
    k = np.nonzero(same)[0]
    if len(k) == 0:
        return p
    m = np.ceil(gap[k] / step).astype(np.int64)  # pieces per gap
    seg = np.repeat(k, m - 1)
    start = np.cumsum(m - 1) - (m - 1)
    j = np.arange(len(seg)) - np.repeat(start, m - 1) + 1  # 1 … m−1 within each gap
    f = (j / np.repeat(m, m - 1))[:, None]
    return np.vstack([p, a[seg] + f * d[seg]])
