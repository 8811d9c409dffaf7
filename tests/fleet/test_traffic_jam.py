"""Traffic-layer jams (fleet/traffic/pibt.py with the manager's planning pattern): robots with a full plan window
are *frozen* (plan no move of their own) but can still be pushed, and a frozen robot pushed by a lower-priority
chain may only move on. Reproduced small from the 100-robot warehouse runs (docs/benchmarks-fleet.md):
- a jam at a junction of two-wide aisles with lanes, like the central aisle's: every robot arrives within a
  bound of steps, the planned configurations never have a vertex or swap conflict, and no robot goes long
  without coming closer to its goal;
- two robots meeting head-on in a one-lane aisle while each is frozen in turn (its queued move not yet
  executed when the other plans): without the move-on rule each pushes the other back in turn, forever.

Planning is simulated as the manager does it (one PIBT step on the robots' planned tails per tick, robots
with `window` moves queued are frozen), with execution reduced to each robot taking its next queued move every
`period` ticks (robots of different speeds): no physics, steps only, so no timing."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.sparse import csr_matrix

from fleet.traffic import PIBT
from fleet.traffic.lanes import DirectedFields, highways
from planning.distance_fields import DistanceFields


def grid(free: Sequence[str], lanes: bool) -> tuple[list[list[int]], DistanceFields, dict[tuple[int, int], int]]:
    """A 4-connected graph of the '.' cells of an ASCII map (row 0 at the top), with lanes (highway 4) or not."""
    ny = len(free)
    cells = [(x, ny - 1 - r) for r, row in enumerate(free) for x, ch in enumerate(row) if ch == "."]
    node = {c: k for k, c in enumerate(cells)}
    rows, cols = [], []
    for (x, y), k in node.items():
        for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            m = node.get((x + dx, y + dy))
            if m is not None:
                rows.append(k)
                cols.append(m)
    adj = csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(cells), len(cells)))
    neighbours = [adj.indices[adj.indptr[i]:adj.indptr[i + 1]].tolist() for i in range(len(cells))]
    if lanes:
        adj = highways(adj, np.array(cells), 4.0)
        return neighbours, DirectedFields(adj), node
    return neighbours, DistanceFields(adj), node


def simulate(neighbours: list[list[int]], fields: DistanceFields, starts: list[int], goals: list[int],
             priority: np.ndarray, periods: Sequence[int], *, window: int = 1, push_frozen: bool = True,
             move_on: bool = True, urgent: int = 12, ticks: int = 400, seed: int = 0) -> tuple[bool, int, int]:
    """Plan as the traffic manager does until every robot's executed cell is its goal. Returns (all arrived,
    ticks taken, longest run of ticks any robot went without coming closer to its goal (executed cells)).
    Priorities as the manager's: `priority` while a robot's plan does not end at its goal, the lowest once it
    does; aging: a robot not closer for `urgent` ticks outranks all others until it arrives (earliest first).
    Checks every planned step for vertex and swap conflicts."""
    pibt = PIBT(neighbours, fields.to, seed)
    pibt.push_frozen, pibt.move_on = push_frozen, move_on
    n = len(starts)
    tails, at = list(starts), list(starts)
    queues: list[list[int]] = [[] for _ in range(n)]
    best = [float(fields.to(goals[i])[at[i]]) for i in range(n)]
    since, longest = [0] * n, 0
    urgent_at = np.full(n, np.inf)
    for t in range(ticks):
        for i in range(n):  # execution: robot i takes its next planned cell every periods[i] ticks
            if queues[i] and t % periods[i] == 0:
                at[i] = queues[i].pop(0)
                d = float(fields.to(goals[i])[at[i]])
                if d < best[i]:
                    best[i], since[i] = d, t
        longest = max(longest, *(t - s for s, a, g in zip(since, at, goals, strict=True) if a != g), 0)
        if at == goals and not any(queues):
            return True, t, longest
        frozen = [i for i in range(n) if len(queues[i]) >= window]
        late = np.array([at[i] != goals[i] and t - since[i] >= urgent for i in range(n)]) & np.isinf(urgent_at)
        urgent_at[late] = t
        urgent_at[np.array(at) == np.array(goals)] = np.inf
        prio = np.where(np.array(tails) != np.array(goals), priority, priority * 1e-6)
        prio = np.where(np.isfinite(urgent_at), 1e9 - urgent_at, prio)
        nxt = pibt.step(tails, goals, prio, frozen)
        assert len(set(nxt)) == n, f"vertex conflict at tick {t}: {nxt}"
        assert not any(nxt[i] == tails[j] and nxt[j] == tails[i] != nxt[i]
                       for i in range(n) for j in range(i + 1, n)), f"swap conflict at tick {t}"
        assert all(v == c or v in neighbours[c] for v, c in zip(nxt, tails, strict=True)), "not a move on the graph"
        for i, v in enumerate(nxt):
            if v != tails[i]:
                queues[i].append(v)
                tails[i] = v
    return False, ticks, longest


# Two-wide aisles (rows y 0-1, 4-5, 8-9) crossed by a two-wide centre aisle (x 4-5) and one-lane end columns,
# shelves between: the warehouse's central-aisle junctions in small.
JUNCTIONS = ["..........",
             "..........",
             ".###..###.",
             ".###..###.",
             "..........",
             "..........",
             ".###..###.",
             ".###..###.",
             "..........",
             ".........."]


def test_a_jam_at_the_centre_junction_clears() -> None:
    neighbours, fields, node = grid(JUNCTIONS, lanes=True)
    centre = [c for c in node if 3 <= c[0] <= 6 and 3 <= c[1] <= 6]  # the junction and the cells round it
    aisle = [c for c in node if len(neighbours[node[c]]) >= 3]  # goals in the aisles, not in one-lane stubs
    for trial in range(16):
        rng = np.random.default_rng(trial)
        starts = [centre[j] for j in rng.choice(len(centre), 10, replace=False)]  # 10 robots in 16 cells
        goals: list[tuple[int, int]] = []
        for s in starts:  # a distinct goal ≥ 5 cells away from each robot
            while True:
                g = aisle[int(rng.integers(len(aisle)))]
                if abs(g[0] - s[0]) + abs(g[1] - s[1]) >= 5 and g not in goals:
                    goals.append(g)
                    break
        periods = rng.integers(1, 4, len(starts)).tolist()  # robots of three speeds
        arrived, took, longest = simulate(neighbours, fields, [node[c] for c in starts], [node[c] for c in goals],
                                          rng.random(len(starts)) + 1.0, periods, ticks=200, seed=trial)
        # the goals are ≤ 13 cells away and the slowest robot moves every 3 ticks: ~40 ticks alone
        assert arrived and took <= 60, (trial, took)
        assert longest <= 35, (trial, longest)


# A one-lane column (x 0) closed into a loop by a parallel column (x 3) and two rows, with a side pocket at
# (1, 3): the warehouse's one-lane column x = 1, where two robots met head-on for 149 s (seed 2, window 1).
LOOP = ["...."] + [".##."] * 5 + ["..#."] + [".##."] * 2 + ["...."]


def test_robots_frozen_in_turn_do_not_push_each_other_back_forever() -> None:
    neighbours, fields, node = grid(LOOP, lanes=False)
    starts, goals = [node[(0, 5)], node[(0, 4)]], [node[(0, 2)], node[(0, 8)]]  # head-on; robot 1 outranks 0
    priority = np.array([1.0, 2.0])
    for periods in ((3, 2), (2, 1)):  # the higher robot is the faster: each is frozen while the other plans
        # Without the move-on rule the lower robot, planning while the higher one is frozen, pushes it back;
        # then the higher one pushes it back in turn: neither ever arrives.
        arrived, _, _ = simulate(neighbours, fields, starts, goals, priority, periods, move_on=False, ticks=300)
        assert not arrived
    for periods in ((3, 2), (2, 1), (2, 2), (2, 3), (1, 2), (4, 4), (3, 5)):
        arrived, took, longest = simulate(neighbours, fields, starts, goals, priority, periods, ticks=300)
        slow = max(periods)  # ticks per move of the slower robot
        assert arrived and took <= 20 * slow and longest <= 15 * slow, (periods, took, longest)
