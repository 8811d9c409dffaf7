"""Vectorised motion of the traffic layer's robots along their claimed cells (numpy over all robots).

Each robot follows a reference at progress `s` (in cells) along the straight segment from the centre of the
cell it is leaving; `s` runs on a braking-limited profile: accelerate to the peak speed, and always able to
stop (at the layer's acceleration) before `stop` — the end of what it has claimed (its next cell, or the one
after when that continues straight on) and the point where it would come within `gap` of its leader (the
robot leaving a cell it has claimed), taken from the leader's *ground-truth* position. So a follower moves
as soon as its leader does, and a slow, held or stuck leader simply stops it short: execution is robust to
delays without any timing assumption.
"""

from __future__ import annotations

import numpy as np


def leader_cap(start: np.ndarray, seg: np.ndarray, lead: np.ndarray, gap: float) -> np.ndarray:
    """Per robot, the progress s (units of `seg`) along start + s·seg at which it would come within `gap` of
    `lead` (its leader's position); +inf when the line never comes that close ahead of s = 0."""
    w = start - lead
    a = np.einsum("ij,ij->i", seg, seg)
    b = 2.0 * np.einsum("ij,ij->i", w, seg)
    c = np.einsum("ij,ij->i", w, w) - gap * gap
    disc = b * b - 4.0 * a * c
    root = np.sqrt(np.maximum(disc, 0.0))
    s1 = (-b - root) / (2.0 * a)
    s2 = (-b + root) / (2.0 * a)
    return np.where((disc > 0.0) & (s2 > 0.0), s1, np.inf)


def advance(s: np.ndarray, sd: np.ndarray, stop: np.ndarray, go: np.ndarray, vmax: np.ndarray, accel: float,
            dt: float) -> tuple[np.ndarray, np.ndarray]:
    """One control period of the braking-limited profile: new progress and rate (cells, cells/s). The rate is
    held for the whole period, so it is the largest v with v·dt + v²/(2·accel) ≤ the distance left: the
    profile can always stop in time at `accel`, with no sudden drop at the end."""
    ad = accel * dt
    brake = -ad + np.sqrt(ad * ad + 2.0 * accel * np.maximum(stop - s, 0.0))
    target = np.where(go, np.minimum(sd + accel * dt, vmax), np.maximum(sd - accel * dt, 0.0))
    sd = np.maximum(np.minimum(target, brake), 0.0)
    return np.minimum(s + sd * dt, np.maximum(stop, s)), sd
