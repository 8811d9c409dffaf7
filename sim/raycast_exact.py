"""Exact ray intersections with curved shapes in their own frame (axis z), vectorised over rays.

A ray that starts inside a shape does not see it (as in Bullet's convex ray tests, mostly). Returns t in
units of the direction vector, inf for a miss. Radii and half lengths are per ray or one for all (a float).
Each value is computed by the same float64 operations whichever rays share the call, so a ray's t does not
depend on its batch (the Embree and closed-form paths agree to the bit).
"""

from __future__ import annotations

import numpy as np

Size = np.ndarray | float


def _quadratic_entry(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Smaller root of a t² + b t + c = 0 where it is real and ≥ 0 and the start is outside (c > 0)."""
    disc = b * b - 4 * a * c
    ok = (a > 0) & (disc >= 0) & (c > 0)
    with np.errstate(invalid="ignore", divide="ignore"):  # rows not ok compute garbage, masked below
        t = (-b - np.sqrt(disc)) / (2 * a)
    return np.where(ok & (t >= 0), t, np.inf)


def sphere(o: np.ndarray, d: np.ndarray, r: Size) -> np.ndarray:
    a = np.einsum("ij,ij->i", d, d)
    b = 2 * np.einsum("ij,ij->i", o, d)
    return _quadratic_entry(a, b, np.einsum("ij,ij->i", o, o) - r * r)


def _side(o: np.ndarray, d: np.ndarray, r: Size, h: Size, q: np.ndarray) -> np.ndarray:
    """Entry through the curved side of the finite cylinder |z| ≤ h; q = x² + y² of the starts."""
    a = d[:, 0] ** 2 + d[:, 1] ** 2
    b = 2 * (o[:, 0] * d[:, 0] + o[:, 1] * d[:, 1])
    t = _quadratic_entry(a, b, q - r * r)
    z = o[:, 2] + np.where(np.isfinite(t), t, 0.0) * d[:, 2]
    return np.where(np.abs(z) <= h, t, np.inf)


def cylinder(o: np.ndarray, d: np.ndarray, r: Size, h: Size) -> np.ndarray:
    q = o[:, 0] ** 2 + o[:, 1] ** 2
    inside = (q <= r * r) & (np.abs(o[:, 2]) <= h)
    t = _side(o, d, r, h, q)
    # A cap is entered only from beyond it along z: rays that start between the caps, or run level (a lidar's),
    # cannot enter one, so only the others are tested.
    cap = np.flatnonzero((np.abs(o[:, 2]) > h) & (d[:, 2] != 0))
    if cap.size:
        oc, dc = o[cap], d[cap]
        rc, hc = (v[cap] if isinstance(v, np.ndarray) and v.ndim else v for v in (r, h))
        cap_z = np.where(oc[:, 2] > 0, hc, -hc)  # the cap facing the start
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            tc = (cap_z - oc[:, 2]) / dc[:, 2]
            tc = np.where(np.isfinite(tc), tc, np.inf)
            x = oc[:, 0] + np.where(np.isfinite(tc), tc, 0.0) * dc[:, 0]
            y = oc[:, 1] + np.where(np.isfinite(tc), tc, 0.0) * dc[:, 1]
        cap_ok = np.isfinite(tc) & (tc >= 0) & (x * x + y * y <= rc * rc)
        t[cap] = np.minimum(t[cap], np.where(cap_ok, tc, np.inf))
    return np.where(inside, np.inf, t)


def capsule(o: np.ndarray, d: np.ndarray, r: Size, h: Size) -> np.ndarray:
    z = np.clip(o[:, 2], -h, h)
    q = o[:, 0] ** 2 + o[:, 1] ** 2
    inside = q + (o[:, 2] - z) ** 2 <= r * r
    t = _side(o, d, r, h, q)
    for sign in (-1.0, 1.0):
        c = o.copy()
        c[:, 2] -= sign * h
        t = np.minimum(t, sphere(c, d, r))
    return np.where(inside, np.inf, t)
