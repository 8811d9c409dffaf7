"""Exact ray intersections with curved shapes in their own frame (axis z), vectorised over rays.

A ray that starts inside a shape does not see it (as in Bullet's convex ray tests, mostly). Returns t in
units of the direction vector, inf for a miss.
"""

from __future__ import annotations

import numpy as np


def _quadratic_entry(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Smaller root of a t² + b t + c = 0 where it is real and ≥ 0 and the start is outside (c > 0)."""
    disc = b * b - 4 * a * c
    ok = (a > 0) & (disc >= 0) & (c > 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        t = (-b - np.sqrt(np.where(ok, disc, 0.0))) / np.where(ok, 2 * a, 1.0)
    return np.where(ok & (t >= 0), t, np.inf)


def sphere(o: np.ndarray, d: np.ndarray, r: np.ndarray) -> np.ndarray:
    a = np.einsum("ij,ij->i", d, d)
    b = 2 * np.einsum("ij,ij->i", o, d)
    return _quadratic_entry(a, b, np.einsum("ij,ij->i", o, o) - r * r)


def _side(o: np.ndarray, d: np.ndarray, r: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Entry through the curved side of the finite cylinder |z| ≤ h."""
    a = d[:, 0] ** 2 + d[:, 1] ** 2
    b = 2 * (o[:, 0] * d[:, 0] + o[:, 1] * d[:, 1])
    c = o[:, 0] ** 2 + o[:, 1] ** 2 - r * r
    t = _quadratic_entry(a, b, c)
    z = o[:, 2] + np.where(np.isfinite(t), t, 0.0) * d[:, 2]
    return np.where(np.abs(z) <= h, t, np.inf)


def cylinder(o: np.ndarray, d: np.ndarray, r: np.ndarray, h: np.ndarray) -> np.ndarray:
    inside = (o[:, 0] ** 2 + o[:, 1] ** 2 <= r * r) & (np.abs(o[:, 2]) <= h)
    t = _side(o, d, r, h)
    cap_z = np.where(o[:, 2] > 0, h, -h)  # the cap facing the start
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        tc = (cap_z - o[:, 2]) / d[:, 2]
        tc = np.where(np.isfinite(tc), tc, np.inf)
        x, y = o[:, 0] + np.where(np.isfinite(tc), tc, 0.0) * d[:, 0], o[:, 1] + np.where(np.isfinite(tc), tc,
                                                                                            0.0) * d[:, 1]
    cap_ok = (np.abs(o[:, 2]) > h) & np.isfinite(tc) & (tc >= 0) & (x * x + y * y <= r * r)
    t = np.minimum(t, np.where(cap_ok, tc, np.inf))
    return np.where(inside, np.inf, t)


def capsule(o: np.ndarray, d: np.ndarray, r: np.ndarray, h: np.ndarray) -> np.ndarray:
    z = np.clip(o[:, 2], -h, h)
    inside = o[:, 0] ** 2 + o[:, 1] ** 2 + (o[:, 2] - z) ** 2 <= r * r
    t = _side(o, d, r, h)
    for sign in (-1.0, 1.0):
        c = o.copy()
        c[:, 2] -= sign * h
        t = np.minimum(t, sphere(c, d, r))
    return np.where(inside, np.inf, t)
