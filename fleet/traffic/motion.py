"""Vectorised motion of the traffic layer's robots along their claimed cells (numpy over all robots).

Each robot follows a reference at progress `s` (in cells) along the straight segment from the centre of the
cell it is leaving; `s` runs on a braking-limited profile: accelerate (at the robot's rated acceleration) to the
peak speed, and always able to stop (at the layer's braking rate, below it) before `stop` — the end of what it
has claimed (its next cell, or the one after when that continues straight on) and the point where it would come
within `gap` of its leader (the robot leaving a cell it has claimed), taken from the leader's *ground-truth*
position. So a follower moves as soon as its leader does, and a slow, held or stuck leader simply stops it short:
execution is robust to delays without any timing assumption.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from sim.transforms import wrap_angles

if TYPE_CHECKING:
    from fleet.traffic.manager import TrafficManager

TURN_TOL = 0.25  # rad: a robot faces its next cell within this before it drives (and turns on as it goes)


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
            dt: float, up: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """One control period of the braking-limited profile: new progress and rate (cells, cells/s). The rate is
    held for the whole period, so it is the largest v with v·dt + v²/(2·accel) ≤ the distance left: the
    profile can always stop in time at `accel`, with no sudden drop at the end. It speeds up at `up` (default
    `accel`): how fast it gets going does not change where it can stop."""
    ad = accel * dt
    brake = -ad + np.sqrt(ad * ad + 2.0 * accel * np.maximum(stop - s, 0.0))
    target = np.where(go, np.minimum(sd + (accel if up is None else up) * dt, vmax), np.maximum(sd - ad, 0.0))
    sd = np.maximum(np.minimum(target, brake), 0.0)
    return np.minimum(s + sd * dt, np.maximum(stop, s)), sd


def drive(tm: TrafficManager, now: float, dt: float, pos: np.ndarray, yaw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every robot's (v, ω) this control period: turn to face the next cell, then follow the profile's reference
    along the segment, held back by its leader (numpy over all robots)."""
    xy, cell, sched = tm.grid.xy, tm.grid.cell, tm.sched
    moving = tm.a != tm.b
    seg = xy[tm.b] - xy[tm.a]
    unit = seg / cell
    err = np.where(moving, wrap_angles(np.arctan2(seg[:, 1], seg[:, 0]) + (tm.sign < 0) * math.pi - yaw), 0.0)
    rolling = moving & ((tm.s > 0.0) | (tm.sd > 0.0))
    go = moving & (rolling | (np.abs(err) < TURN_TOL)) & (tm.hold <= now)
    stop = np.where(tm.claim >= 0, 2.0, 1.0)
    me = np.arange(len(tm.names))
    for lead in (sched.leaving[tm.b], np.where(tm.claim >= 0, sched.leaving[tm.claim], -1)):
        ok = (lead >= 0) & (lead != me) & moving
        if ok.any():
            cap = leader_cap(xy[tm.a[ok]], seg[ok], pos[lead[ok]], tm.gap)
            stop[ok] = np.minimum(stop[ok], cap)
    tm.s, tm.sd = advance(tm.s, tm.sd, stop, go, tm.peak * tm.scale, tm.accel, dt, tm.accel_up)
    ref = xy[tm.a] + tm.s[:, None] * seg
    e = ref - pos
    along = e[:, 0] * unit[:, 0] + e[:, 1] * unit[:, 1]
    cross = -e[:, 0] * unit[:, 1] + e[:, 1] * unit[:, 0]
    v = np.where(rolling | go, tm.sign * (tm.sd * cell + 2.0 * np.clip(along, -0.3, 0.1)), 0.0)
    w = np.where(moving, np.clip(4.0 * err + 3.0 * cross * rolling, -tm.max_w, tm.max_w), 0.0)
    return v, w
