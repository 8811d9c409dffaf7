"""Planar velocity → unicycle (v, ω), and the shared geometric terms behaviours add (separation).

A differential-drive robot cannot move sideways, but the point `offset` ahead of its axle can move in
any direction: its velocity is u = v·h + offset·ω·h⊥, which inverts to v = u·h, ω = u·h⊥ / offset
(the near-identity diffeomorphism used for feedback linearisation). Tracking a desired planar velocity
through that point is exact up to the velocity limits.
"""

from __future__ import annotations

import numpy as np

OFFSET = 0.15  # m; fleet/avoidance uses the same point, so behaviours and ORCA agree on what moves


def to_unicycle(u: np.ndarray, yaw: np.ndarray, max_v: np.ndarray, max_w: np.ndarray,
                offset: float = OFFSET) -> np.ndarray:
    """(n, 2) planar velocities → (n, 2) (v, ω), saturated to each robot's limits."""
    c, s = np.cos(yaw), np.sin(yaw)
    v = u[:, 0] * c + u[:, 1] * s
    w = (-u[:, 0] * s + u[:, 1] * c) / offset
    return np.column_stack([np.clip(v, -max_v, max_v), np.clip(w, -max_w, max_w)])


def scale_uniformly(u: np.ndarray, max_speed: float) -> np.ndarray:
    """Scale all rows by one factor so the fastest is at most `max_speed`: Σu (the centroid's motion) keeps
    its direction, and stays zero when it was."""
    top = float(np.hypot(u[:, 0], u[:, 1]).max()) if len(u) else 0.0
    return u * min(1.0, max_speed / top) if top > 0 else u


def saturate(u: np.ndarray, max_speed: np.ndarray | float) -> np.ndarray:
    """Scale each row down to at most `max_speed` (direction kept)."""
    n = np.hypot(u[:, 0], u[:, 1])
    scale = np.minimum(1.0, np.asarray(max_speed) / np.maximum(n, 1e-12))
    return u * scale[:, None]


def pairwise(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rel (n, n, 2) with rel[i, j] = xy[j] − xy[i], dist (n, n) with inf on the diagonal)."""
    rel = xy[None, :, :] - xy[:, None, :]
    d = np.hypot(rel[..., 0], rel[..., 1])
    np.fill_diagonal(d, np.inf)
    return rel, d


def separation(xy: np.ndarray, distance: float) -> np.ndarray:
    """Σ_j (p_i − p_j)/d · (distance − d)/distance over robots closer than `distance`: antisymmetric in
    (i, j), so it never moves the centroid."""
    rel, d = pairwise(xy)
    push = np.clip(distance - d, 0.0, None) / distance / np.maximum(d, 1e-9)  # inf diagonal → 0
    return -(rel * push[..., None]).sum(axis=1)
