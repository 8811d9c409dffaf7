"""The traffic layer's wait events: a robot whose distance to its goal has not improved for `stall_s` opens a
`deadlock` event naming the robots it waits for and how the layer frees it; `deadlock_resolved` closes it when
the robot comes strictly closer than its best, with how long it took."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from fleet.traffic.manager import TrafficManager


def open_stalls(tm: TrafficManager, now: float) -> None:
    """Open an event for every robot with a goal that has not come closer for stall_s (once per wait)."""
    stuck = tm.pending & (now - tm.best_at >= tm.stall_s)
    if not stuck.any():
        return
    for i in np.flatnonzero(stuck).tolist():
        name = tm.names[i]
        if name in tm.open_stalls:
            continue
        blockers = tm.sched.blockers(i)
        if blockers:
            why = (f"waited in the action-dependency graph for {', '.join(tm.names[k] for k in blockers)} "
                   "to clear its next cell (acyclic: each of them moves on without waiting for it)")
        else:
            field = tm.grid.fields.to(int(tm.goal[i]))
            here = int(tm.sched.tail[i])
            ahead = [v for v in tm.grid.neighbours[here] if field[v] < field[here]]
            blockers = sorted({int(k) for k in tm.sched.at[ahead].tolist() if k >= 0 and k != i}) if ahead else []
            why = ("its priority grew until PIBT's priority inheritance pushed "
                   f"{', '.join(tm.names[k] for k in blockers) or 'the robots ahead'} aside")
        others = [tm.names[k] for k in blockers]
        tm.open_stalls[name] = (now, others, why)
        tm.stats["deadlocks"] += 1
        tm.service.events.publish(
            now, "deadlock", (name, *others), f"{name} has not come closer to its goal for {tm.stall_s:g} s; "
            f"waiting for {', '.join(others) or 'its turn'}; resolution: the schedule is acyclic and its "
            "priority grows, so PIBT and the ADG free it", strategy="adg_pibt")


def close_stall(tm: TrafficManager, i: int, now: float) -> None:
    """Robot i has just come closer than its best: close its open wait, if any."""
    name = tm.names[i]
    if name not in tm.open_stalls:
        return
    start, others, why = tm.open_stalls.pop(name)
    took = now - start + tm.stall_s
    if math.isfinite(tm.urgent_at[i]):
        why += (f"; urgent (top priority, aging) since it had waited {tm.urgent_s:g} s, "
                f"{now - tm.urgent_at[i]:.1f} s ago")
    tm.stats["resolved"] += 1
    tm.stats["longest_deadlock_s"] = max(tm.stats["longest_deadlock_s"], took)
    tm.service.events.publish(
        now, "deadlock_resolved", (name, *others), f"{name} moving towards its goal again after "
        f"{took:.1f} s: {why}", strategy="adg_pibt", duration=took)
