"""The traffic layer's execution events (one robot at a time, O(changed) per tick): cells released once a robot's
footprint is clear of them, arrivals at the end of a segment, and claims of the next planned cell when the
schedule allows (schedule.py: first in the cell's FIFO, nobody in or entering it). The motion between events is
motion.py's; the plan they execute is PIBT's (manager.py)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from fleet.traffic.schedule import BIG
from sim.transforms import wrap_angle

if TYPE_CHECKING:
    from fleet.traffic.manager import TrafficManager

ARRIVE_TOL = 0.12  # m: a robot stopping at a cell centre has arrived this close to it


def release_cleared(tm: TrafficManager, pos: np.ndarray) -> None:
    """Cells left behind are released once the footprint is `gap` clear of their centre (ground truth)."""
    moving = tm.a != tm.b
    rel = moving & ~tm.released & (np.hypot(*(pos - tm.grid.xy[tm.a]).T) >= tm.gap)
    for i in np.flatnonzero(rel).tolist():
        tm.sched.release(i, int(tm.a[i]))
    tm.released |= rel


def arrivals(tm: TrafficManager, pos: np.ndarray, now: float) -> None:
    """Robots at the end of their segment: on into the cell claimed on the way, or at rest at the centre."""
    moving = tm.a != tm.b
    near = np.hypot(*(pos - tm.grid.xy[tm.b]).T) < ARRIVE_TOL
    for i in np.flatnonzero(moving & (tm.s >= 1.0 - 1e-9) & ((tm.claim >= 0) | near)).tolist():
        arrive(tm, i, now)


def claims(tm: TrafficManager, yaw: np.ndarray) -> None:
    """Robots at rest take their next cell when the schedule lets them; robots on the move take the one after
    when it continues straight on (no stop at the centre)."""
    sched = tm.sched
    queued = sched.head_step < BIG
    moving = tm.a != tm.b
    for i in np.flatnonzero(queued & ~moving).tolist():
        if sched.can_claim(i):
            start(tm, i, float(yaw[i]))
    on = np.flatnonzero(queued & moving & (tm.claim < 0))
    if on.size:
        nv = np.fromiter((sched.queue[i][0][0] for i in on.tolist()), np.int64, on.size)
        g, a, b = tm.grid.ij, tm.a[on], tm.b[on]
        straight = np.all(g[nv] - g[b] == g[b] - g[a], axis=1)
        for i in on[straight].tolist():
            if sched.can_claim(i):
                tm.claim[i], tm.claim_step[i] = sched.claim(i)


def start(tm: TrafficManager, i: int, yaw: float) -> None:
    """Robot i, at rest, claims its next planned cell and starts towards it (reversing into a cell behind)."""
    v, step = tm.sched.claim(i)
    tm.sched.depart(i, int(tm.a[i]))
    tm.b[i], tm.seg_step[i] = v, step
    tm.s[i] = tm.sd[i] = 0.0
    tm.released[i] = False
    d = tm.grid.xy[v] - tm.grid.xy[tm.a[i]]
    turn = wrap_angle(math.atan2(d[1], d[0]) - yaw)
    tm.sign[i] = -1.0 if abs(turn) > math.pi / 2 else 1.0
    tm.stats["moves"] += 1


def arrive(tm: TrafficManager, i: int, now: float) -> None:
    """Robot i reaches the end of its segment: straight on into its claimed cell, or to rest; then its progress."""
    sched = tm.sched
    if not tm.released[i]:
        sched.release(i, int(tm.a[i]))
    if tm.claim[i] >= 0:  # straight on into the cell claimed on the way
        sched.depart(i, int(tm.b[i]))
        tm.a[i], tm.b[i], tm.claim[i] = tm.b[i], tm.claim[i], -1
        tm.seg_step[i], tm.claim_step[i] = tm.claim_step[i], BIG
        tm.s[i] -= 1.0
        tm.released[i] = False
        tm.stats["moves"] += 1
    else:
        tm.a[i] = tm.b[i]
        tm.s[i] = tm.sd[i] = 0.0
        tm.seg_step[i] = BIG
        tm.released[i] = True
        tm.rest_at[i] = now
    tm._progress(i, now)
