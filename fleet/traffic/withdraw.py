"""Withdrawing planned moves that have not started, so that a waiting robot can go before robots planned
through its next cell earlier (the traffic layer's `withdraw` setting; docs/benchmarks-fleet.md, 17g).

The schedule (schedule.py) only ever appends: a move, once planned, keeps its place in its cell's FIFO, and an
urgent robot whose next cell was planned for others first waits for all of them and for everything they wait
for. Here a robot's queue is cut back to a cell X it already holds or is planned to reach (it will stay in X
until PIBT plans for it again), which is safe when no robot that stays is followed, in the FIFO of the cell it
stays in, by another robot's move that is kept. The robots following it there are cut back too, to the cell
before X, recursively; the set is applied only if it closes (within a budget) and holds only robots of lower
priority than the one it frees. After the cut, every FIFO keeps its remaining moves in their order, each
robot's queue loses a suffix, and a kept move that followed a withdrawn one in a FIFO now follows the kept
move before it, which it already followed through the withdrawn one: the action-dependency graph only loses
edges implied by paths, so it stays acyclic, a cell is still entered by one robot at a time (at[] and claimed
moves are untouched), and the planned tails stay distinct (nobody is planned into a cell after a robot that
now stays there)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from fleet.traffic.priority import URGENT, priorities
from fleet.traffic.schedule import BIG, Schedule

if TYPE_CHECKING:
    from fleet.traffic.manager import TrafficManager


def _cells(sched: Schedule, i: int, here: int) -> list[int]:
    return [here, *(v for v, _ in sched.queue[i])]


def _entry_index(cells: list[int], v: int, rank: int) -> int:
    """Index in `cells` (1-based queue entries) of the robot's rank-th (0-based) planned entry into v."""
    seen = 0
    for k in range(1, len(cells)):
        if cells[k] == v:
            if seen == rank:
                return k
            seen += 1
    raise ValueError("entry not in the robot's queue")


def cut_set(sched: Schedule, here: np.ndarray, starts: dict[int, int], allowed: np.ndarray,
            budget: int = 64) -> dict[int, int] | None:
    """The robots to cut back and the cell index each stays at (its cells: here, then its queue), starting
    from `starts` and closed under "a robot planned into a cell after one that stays there is cut back to the
    cell before it"; None if a robot not `allowed` would be cut or the set exceeds `budget` robots."""
    plan: dict[int, int] = {}
    todo = list(starts.items())
    while todo:
        j, p = todo.pop()
        if p < 0 or not allowed[j]:
            return None
        if j in plan and plan[j] <= p:
            continue
        plan[j] = p
        if len(plan) > budget:
            return None
        cells = _cells(sched, j, int(here[j]))
        x = cells[p]
        mine = sum(1 for k in range(1, p + 1) if cells[k] == x)  # j's entries into X up to p: they stay
        rank: dict[int, int] = {}
        for m in sched.fifo[x]:
            r = rank.get(m, 0)
            rank[m] = r + 1
            if m == j:
                continue
            if rank.get(j, 0) >= mine:  # planned into X after j's entry at p (or after j took X, p = 0)
                todo.append((m, _entry_index(_cells(sched, m, int(here[m])), x, r) - 1))
    return plan


def cut(sched: Schedule, here: np.ndarray, plan: dict[int, int]) -> int:
    """Apply a closed cut set (cut_set): each robot's queue after its stay index is withdrawn; returns the moves
    withdrawn."""
    cells = {j: _cells(sched, j, int(here[j])) for j in plan}
    touched: dict[int, set[int]] = {}  # cell -> robots with an entry into it withdrawn
    for j, p in plan.items():
        for v in cells[j][p + 1:]:
            touched.setdefault(v, set()).add(j)
    for v, robots in touched.items():
        keep = {j: cells[j][1:plan[j] + 1].count(v) for j in robots}  # entries into v kept, per robot
        seen: dict[int, int] = {}
        kept = []
        for m in sched.fifo[v]:
            r = seen.get(m, 0)
            seen[m] = r + 1
            if m in keep and r >= keep[m]:
                continue
            kept.append(m)
        sched.fifo[v].clear()
        sched.fifo[v].extend(kept)
    total = 0
    for j, p in plan.items():
        q = sched.queue[j]
        total += len(q) - p
        moves = list(q)[:p]
        q.clear()
        q.extend(moves)
        sched.head_step[j] = q[0][1] if q else BIG
        sched.tail[j] = cells[j][p]
        sched.before[j] = cells[j][p - 1] if p >= 1 else -1
    return total


def free_ahead(sched: Schedule, here: np.ndarray, priority: np.ndarray, waiting: list[int],
               budget: int = 64) -> int:
    """For each waiting robot (highest priority first) whose next cell's FIFO has moves of other robots ahead of
    it, cut those robots back to the cell before it (and whoever follows them: cut_set), if all of them rank
    below it. Returns the moves withdrawn."""
    total = 0
    for u in sorted(waiting, key=lambda k: -priority[k]):
        if not sched.queue[u]:
            continue
        v = sched.queue[u][0][0]
        starts: dict[int, int] = {}
        for k in sched.fifo[v]:
            if k == u:
                break
            if k not in starts:
                starts[k] = _entry_index(_cells(sched, k, int(here[k])), v, 0) - 1
        if not starts:
            continue
        plan = cut_set(sched, here, starts, priority < priority[u], budget)
        if plan is not None:
            total += cut(sched, here, plan)
    return total


def flush(sched: Schedule, here: np.ndarray) -> int:
    """Withdraw every unstarted move (each robot cut back to the cell it holds or has claimed): always a closed
    cut set, since nobody is then planned into any cell. PIBT then re-plans from the committed configuration."""
    total = 0
    for j, q in enumerate(sched.queue):
        if q:
            total += len(q)
            for v, _ in q:
                sched.fifo[v].clear()
            q.clear()
            sched.tail[j] = here[j]
            sched.before[j] = -1
    sched.head_step[:] = BIG
    return total


def crowded(tm: TrafficManager) -> bool:
    """Admission holds goals: the layer has more robots with work than it lets drive (a crowded fleet)."""
    return tm.admission is not None and bool(tm.admission.queue)


def withdraw_step(tm: TrafficManager, now: float) -> None:
    """The layer's `withdraw` setting, once per control tick: loops, moves ahead of urgent robots at rest, or a
    flush every `flush_s` (`flush`: always; `crowded`, the default: while admission holds goals).

    `crowded` because the flush pays only in a crowd: there stale moves (held robots' pushes, a stream's moves
    planned cells ahead) are what the long waits queue behind, and re-planning every second from the committed
    cells cut the 300-robot warehouse's waits over 30 s from 48 to 7 over 8 × 10 sim-minutes (with `bound`'s fixed
    limit). In a small packed room with persistent goals a flush every second breaks the multi-move manoeuvres
    PIBT plans and the robots never settle (4 robots rotating round a 2 × 2 block: still moving after 240 s;
    without it they are there in 10 s), and such fleets never have a goal held."""
    due = now >= tm._flush_at and (tm.withdraw == "flush" or (tm.withdraw == "crowded" and crowded(tm)))
    if tm.withdraw in ("flush", "crowded") and not due:
        return  # between flushes (every tick, the default's case): nothing to compute
    here = np.where(tm.claim >= 0, tm.claim, tm.b)
    if tm.withdraw in ("loops", "both"):
        for i in np.flatnonzero(tm.sched.queued >= 2).tolist():
            tm.stats["withdrawn"] += tm.sched.withdraw_loops(i, int(here[i]))
    if due:
        tm._flush_at = now + tm.flush_s
        tm.stats["withdrawn"] += flush(tm.sched, here)
    if tm.withdraw in ("ahead", "both"):
        priority = priorities(tm, now)
        waiting = (priority >= URGENT) & (tm.a == tm.b) & (tm.sched.head_step < BIG)
        tm.stats["withdrawn"] += free_ahead(tm.sched, here, priority, np.flatnonzero(waiting).tolist())
