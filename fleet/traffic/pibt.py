"""PIBT: priority inheritance with backtracking (Okumura et al., IJCAI 2019 / AIJ 2022), one synchronous step.

Every agent, highest priority first, takes the free neighbouring node (or its own) closest to its goal by the
shared cost-to-go field. An agent whose wanted node is occupied by an undecided agent lends that agent its
priority, and the lower agent must move out of the way (never into the pusher's node: no swaps); if it cannot,
the pusher backtracks and tries its next node. Vertex and swap conflicts are impossible by construction, and
with priorities that grow while an agent is away from its goal, the highest-priority agent always gets closer,
so every agent reaches its goal in finite time on graphs where adjacent nodes lie on a common cycle (the
lifelong-MAPF property the traffic layer relies on).

Changes for real robots (fleet/traffic/manager.py executes the steps asynchronously):
- an agent does not follow another around a closed loop of moves (a rotation): each robot would wait for the
  one ahead to clear its cell. The reachability argument above assumes rotations are allowed, so in packed
  corners the guarantee is weaker (a push chain that would close a loop must end elsewhere or wait);
- `frozen` agents (robots with enough moves queued already) plan no move of their own this step, but can still
  be pushed (one more move appended to their queue). Frozen agents that could not be pushed were the main cause
  of the long waits in the 100-robot warehouse: the highest-priority robot found its next node held by a frozen
  one and waited a whole step, step after step, in the busy central aisle (docs/benchmarks-fleet.md);
- among nodes equally close to the goal, the one straight on comes first (a turn costs a stop);
- `yield_aside`: a pushed agent, among nodes equally close to its goal, takes one its pusher does not need next
  (no closer to the pusher's goal than its own node), so an agent met head-on steps aside rather than
  retreating before its pusher node after node;
- `box`: crossing cells (crossings.py). An agent planning its own move, on a task (`box_for`) and not urgent, enters
  one from outside only with a way out towards its goal (do not block the box);
- `hot` / `keep_off`: an agent marked in `keep_off` (the layer: a robot whose goal admission holds, on its way to
  park) plans no move of its own into a `hot` cell (the next cells of the ways of robots in a wait,
  admission_wait.py); it can still be pushed there, and it may leave one;
- `hold_ground`: agents that hold their ground (the layer: robots with a goal, not urgent, that have waited
  `hold_ground_s` without coming closer, priority.holding_ground). When pushed, such an agent takes only nodes no
  farther from its goal; if it has none, its pusher tries another node or waits. Urgent agents are never marked,
  so the highest-priority robot is held up at most until the agent in its way becomes urgent in turn;
- `traps`: the cells of one-way corridors. A pushed agent outside them is never pushed into one that does not bring
  it closer to its goal: it could only drive through, however long the corridor (on the warehouse one push into
  the one-lane cross row sent a robot 43 cells round, a 51 s wait); its pusher tries another node or waits.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np


class PIBT:
    def __init__(self, neighbours: Sequence[Sequence[int]], field: Callable[[int], np.ndarray], seed: int = 0) -> None:
        self.neighbours = neighbours
        self.field = field
        self.rng = np.random.default_rng(seed)
        self.pushes: list[tuple[int, int]] = []  # (pusher, pushed) of the last step: priority inheritance
        self.yield_aside = True  # a pushed agent prefers, among equally good nodes, one off its pusher's way
        self.push_frozen = True  # frozen agents do not plan a move of their own but can still be pushed
        self.frozen: set[int] = set()
        self.priority = np.zeros(0)
        self.root = 0.0  # priority of the agent whose push chain is being planned
        self.move_on = True  # a frozen agent pushed by a lower chain may only move on (no farther from its goal)
        self.traps: set[int] = set()  # one-way corridor cells: never pushed into one that leads away (module doc)
        self.box: set[int] = set()  # crossing cells entered only with a way out (crossings.py)
        self.box_exempt = np.inf  # agents of at least this priority enter crossings regardless (the urgent)
        self.box_for: np.ndarray | None = None  # the agents the rule applies to (None: all; the layer: with a goal)
        self.hot: set[int] = set()  # cells `keep_off` agents do not enter on a move of their own (module doc)
        self.keep_off: np.ndarray | None = None
        self.hold_ground: np.ndarray | None = None  # agents not pushed farther from their goals (module doc)

    def step(self, cur: Sequence[int], goals: Sequence[int], priority: np.ndarray,
             frozen: Sequence[int] = (), prefer: Sequence[int] | None = None) -> list[int]:
        """The next node of every agent (its own node when it waits). `frozen` agents (the traffic layer's robots
        with enough moves queued already) plan no move of their own: they stay unless a higher agent pushes them
        (`push_frozen`; without it they are obstacles this step).
        `prefer`: per agent, the node that goes straight on (-1: none); among nodes equally close to the goal it
        comes first, so robots do not zig-zag (every turn costs a real robot a stop and a turn in place)."""
        self.cur, self.goals = list(cur), list(goals)
        self.prefer = list(prefer) if prefer is not None else [-1] * len(self.cur)
        self.occ = {v: i for i, v in enumerate(self.cur)}
        self.nxt = [-1] * len(self.cur)
        self.reserved: dict[int, int] = {}
        self.pushes = []
        if not self.push_frozen:
            for i in frozen:
                self.nxt[i] = self.cur[i]
                self.reserved[self.cur[i]] = i
        self.frozen = set(frozen)
        self.priority = priority
        for i in np.argsort(-priority, kind="stable").tolist():
            if self.nxt[i] < 0 and i not in self.frozen:
                self.root = float(priority[i])
                self._pibt(i, None)
        for i in frozen:  # not pushed by anyone: they stay (nobody took their node without pushing them)
            if self.nxt[i] < 0:
                self.nxt[i] = self.cur[i]
                self.reserved[self.cur[i]] = i
        return self.nxt

    def _pibt(self, i: int, pusher: int | None) -> bool:
        c = self.cur[i]
        cands = [c, *self.neighbours[c]]
        dist = self.field(self.goals[i])
        # Two ways an agent may only move on (no farther from its goal):
        # - frozen and pushed by a chain of lower priority: a follower extends its leader's plan, it cannot push it
        #   back (two robots doing that to each other in turn, each frozen while the other plans, was a livelock in
        #   a one-lane aisle);
        # - pushed while it holds its ground (`hold_ground`, module doc).
        frozen_under = self.move_on and i in self.frozen and self.priority[i] > self.root
        holding = pusher is not None and self.hold_ground is not None and bool(self.hold_ground[i])
        if frozen_under or holding:
            cands = [v for v in cands if dist[v] <= dist[c]]
        if pusher is not None and self.traps and c not in self.traps:
            cands = [v for v in cands if v not in self.traps or dist[v] < dist[c]]
        if (pusher is None and self.box and c not in self.box and self.priority[i] < self.box_exempt
                and (self.box_for is None or self.box_for[i])):
            cands = [v for v in cands if v not in self.box or self._has_exit(i, v, dist)]
        if pusher is None and self.hot and self.keep_off is not None and self.keep_off[i]:
            cands = [v for v in cands if v == c or v not in self.hot]
        straight = np.array([v != self.prefer[i] for v in cands])
        if pusher is not None and self.yield_aside:
            # Off the pusher's way: a node the pusher does not need next (no closer to its goal than i's node).
            # Otherwise a robot pushed head-on in an aisle retreats before its pusher cell after cell.
            fp = self.field(self.goals[pusher])
            on_way = fp[cands] < fp[c]
        else:
            on_way = np.zeros(len(cands), bool)
        order = np.lexsort((self.rng.random(len(cands)), straight, on_way, dist[cands]))  # nearest, aside, straight
        for v in (cands[k] for k in order):
            if v in self.reserved or (pusher is not None and v == self.cur[pusher]):
                continue
            k = self.occ.get(v)
            if k is not None and k != i and self.nxt[k] >= 0 and self._closes_loop(i, k):
                continue
            self.reserved[v] = i
            self.nxt[i] = v
            if k is not None and k != i and self.nxt[k] < 0:
                self.pushes.append((i, k))
                if not self._pibt(k, i):  # k stays put: v is taken after all, try the next node
                    if self.reserved.get(v) == i:
                        del self.reserved[v]
                    self.nxt[i] = -1
                    continue
            return True
        self.nxt[i] = c  # nowhere to go: wait (a pusher's claim on c is overridden, and it backtracks)
        self.reserved[c] = i
        return False

    def _has_exit(self, i: int, v: int, dist: np.ndarray) -> bool:
        """Would i, in crossing cell v, have a way on: its goal, or a neighbour of v closer to its goal that nobody
        has taken in this step and whose robot, if any, has already been planned out of it (crossings.py)?"""
        if v == self.goals[i]:
            return True
        for u in self.neighbours[v]:
            if dist[u] < dist[v] and u not in self.reserved:
                k = self.occ.get(u)
                if k is None or (self.nxt[k] >= 0 and self.nxt[k] != u):
                    return True
        return False

    def _closes_loop(self, i: int, k: int) -> bool:
        """Would i entering k's node (k already moving on) close a loop of agents following each other?"""
        m = k
        for _ in range(len(self.cur)):
            v = self.nxt[m]
            if v < 0 or v == self.cur[m]:
                return False
            m2 = self.occ.get(v)
            if m2 is None:
                return False
            if m2 == i:
                return True
            m = m2
        return True
