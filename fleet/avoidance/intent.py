"""Preferred planar velocities for ORCA: where each robot wants to go, not only how it steers right now.

A path tracker that has to swing round an obstacle first commands a turn on the spot; mapped to the tracked
point that is a sideways velocity, which ORCA cannot trade against the other robot (both end up nose to
nose). For a robot running a go-to task the preference is therefore the direction to a lookahead point on
its planned path, at its commanded speed (at least `min_speed`). Other robots keep their own command.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from fleet.tasks.basic import GoToTask
from planning.nav_types import NavState

if TYPE_CHECKING:
    from fleet.avoidance.types import FleetFrame
    from fleet.fleet_view import FleetView


def lookahead_point(path: np.ndarray, xy: np.ndarray, ahead: float) -> tuple[np.ndarray, float]:
    """The point `ahead` metres along `path` past its point closest to `xy`, and the length left after it."""
    a, b = path[:-1], path[1:]
    seg = b - a
    seg_len = np.hypot(seg[:, 0], seg[:, 1])
    t = np.clip(np.einsum("ij,ij->i", xy - a, seg) / np.maximum(seg_len**2, 1e-12), 0.0, 1.0)
    proj = a + t[:, None] * seg
    k = int(np.argmin(np.hypot(*(proj - xy).T)))
    s = np.concatenate([[0.0], np.cumsum(seg_len)])
    target = min(s[k] + t[k] * seg_len[k] + ahead, s[-1])
    x = np.interp(target, s, path[:, 0])
    y = np.interp(target, s, path[:, 1])
    return np.array([x, y]), float(s[-1] - target)


def preferred_velocities(view: FleetView, fr: FleetFrame, offset: float, lookahead: float,
                         min_speed: float) -> np.ndarray:
    """(n, 2) preferred velocities of the tracked points (offset ahead of each axle)."""
    h = np.column_stack([np.cos(fr.yaw), np.sin(fr.yaw)])
    hp = np.column_stack([-h[:, 1], h[:, 0]])
    pref = fr.cmd[:, 0:1] * h + offset * fr.cmd[:, 1:2] * hp
    for i in np.flatnonzero(fr.active):
        task = view.active_task(fr.names[i])
        nav = task.nav if isinstance(task, GoToTask) else None
        if nav is None or not nav.plans or nav.state is not NavState.TRACKING:
            continue
        point = fr.xy[i] + offset * h[i]
        target, left = lookahead_point(nav.plans[-1].path, point, lookahead)
        d = target - point
        dist = float(np.hypot(*d))
        if dist < 1e-6:
            continue
        speed = max(abs(float(fr.cmd[i, 0])), min(min_speed, dist + left))
        pref[i] = d / dist * speed
    return pref
