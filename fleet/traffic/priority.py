"""PIBT's priority of the traffic layer's robots: the time since the goal was given (or since the robot last came
closer), and aging: a robot without progress for `urgent_s` outranks every robot that is not urgent."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from fleet.traffic.admission import held_mask

if TYPE_CHECKING:
    from fleet.traffic.manager import TrafficManager

URGENT = 1e9  # s: added to an urgent robot's priority (above any goal age)


def priorities(tm: TrafficManager, now: float, held: np.ndarray | None = None) -> np.ndarray:
    """PIBT's priority of every robot now (marks robots that have become urgent). `held`: admission.held_mask, if
    the caller has it already."""
    since = tm.best_at if tm.priority == "since_progress" else tm.since
    priority = (now - since) * (tm.goal != tm.sched.tail) + tm._tie
    if tm.parking is not None and tm.admission is not None and tm.admission.queue:
        held = held_mask(tm) if held is None else held  # on the way to park: below every goal
        priority[held] = tm._tie[held]
    if tm.urgent_s is not None:
        # Aging: a robot that has not come closer for urgent_s outranks every other robot until it reaches
        # its goal (earliest first among the urgent, a fixed order), so two robots cannot take turns
        # pushing each other back as their priorities cross.
        late = tm.pending & np.isinf(tm.urgent_at) & (now - tm.best_at >= tm.urgent_s)
        tm.urgent_at[late] = now
        tm.urgent_d[late] = tm.best[late]
        urgent = np.isfinite(tm.urgent_at)
        # Among the urgent: the longest without progress first (since_progress), so an urgent robot pushed
        # back by older urgent ones gets ahead of them until it has regained its ground; each change of order
        # needs a robot to come strictly closer than its best, so the order cannot cycle for ever.
        order = tm.best_at if tm.urgent_rank == "since_progress" else tm.urgent_at
        priority = np.where(urgent, URGENT + (now - order), priority)
    return priority


def holding_ground(tm: TrafficManager, now: float) -> np.ndarray | None:
    """Robots that hold their ground (PIBT's `hold_ground`; None: the rule is off): a goal, not urgent, and
    `hold_ground_s` or more since they last came closer. A push may move them aside or on, not back. A wait of 30 s
    on the 300-robot warehouse was mostly ground lost to pushes just before the robot became urgent, won back at
    3-4 s a cell (docs/benchmarks-fleet.md, eighteenth landing); the rule ends when aging makes the robot urgent, so
    an urgent robot it stands in the way of waits at most `urgent_s - hold_ground_s` for it. Without aging
    (`urgent_s` None) nothing would end a hold (two robots met head-on could wait for ever), so the rule applies
    only with aging on."""
    if tm.hold_ground_s is None or tm.urgent_s is None:
        return None
    return tm.pending & np.isinf(tm.urgent_at) & (now - tm.best_at >= tm.hold_ground_s)


def lookahead(tm: TrafficManager) -> np.ndarray:
    """Moves each robot may have planned ahead: `window`, and `urgent_window` for an urgent robot with a goal.
    An urgent robot's next move is planned while the one before is still queued (it waits to claim that cell), so
    it takes its place in the FIFO of the cell after before robots planned later, which it would otherwise wait for
    there too, and PIBT pushes the robots in that cell out of its way a step earlier. Opt-in (`urgent_window` 1 by
    default): on the warehouse over 10 sim-minutes, 2 cut the 100-robot waits over 25 s by 29 % (64 seeds) but
    raised the 300-robot ones by 44 % (32 seeds), also when only the top urgent robot looks ahead
    (docs/benchmarks-fleet.md, thirteenth landing)."""
    urgent = np.isfinite(tm.urgent_at) & tm.pending
    return np.where(urgent, max(tm.window, tm.urgent_window), tm.window)


def urgent_room(tm: TrafficManager) -> np.ndarray:
    """Urgent robots with room in a look-ahead longer than `window`: the layer plans a step for them (the others
    plan only once their queue is empty)."""
    if tm.urgent_window <= tm.window:
        return np.zeros(len(tm.names), bool)
    return (tm.sched.queued < lookahead(tm)) & np.isfinite(tm.urgent_at) & tm.pending
