"""The traffic layer's wait-for graph, and which robots in it are on or behind a cycle (a true deadlock).

Per robot at rest: with a move queued, it waits for the robots ahead of it for its next cell (in it, leaving it,
or before it in the cell's FIFO: the action-dependency graph's edges, acyclic by construction, schedule.py);
with nothing queued and a goal, for the robots in the neighbouring cells closer to its goal (PIBT must move one
of them). Moving robots (between two cells) and robots without a goal wait for nobody. Counting a robot with
nothing queued as waiting for *every* closer neighbour over-approximates (one of them giving way is enough),
so "on or behind a cycle" is an upper bound on deadlock, never an under-count. Used by benchmarks/fleet.py to
split the layer's waits into cycles and queues.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

if TYPE_CHECKING:
    from fleet.traffic.manager import TrafficManager


def reaches_cycle(n: int, edges: Sequence[tuple[int, int]]) -> np.ndarray:
    """Per node of the directed graph (i → j: i waits for j), does it lie on or lead to a cycle?"""
    out = np.zeros(n, bool)
    if not edges:
        return out
    e = np.asarray(edges, np.int64)
    g = csr_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n))
    _, comp = connected_components(g, directed=True, connection="strong")
    size = np.bincount(comp, minlength=n)
    on = (size[comp] > 1) | (np.asarray(g.diagonal()) > 0)
    back: list[list[int]] = [[] for _ in range(n)]  # reversed edges: who waits for j
    for i, j in e.tolist():
        back[j].append(i)
    todo = deque(np.flatnonzero(on).tolist())
    out[on] = True
    while todo:
        j = todo.popleft()
        for i in back[j]:
            if not out[i]:
                out[i] = True
                todo.append(i)
    return out


def wait_for_edges(tm: TrafficManager) -> list[tuple[int, int]]:
    """The layer's wait-for graph now (see the module doc)."""
    sched, edges = tm.sched, []
    at_rest = tm.a == tm.b
    for i in np.flatnonzero(at_rest).tolist():
        if sched.queue[i]:
            edges += [(i, k) for k in sched.blockers(i)]
        elif tm.pending[i]:
            here, field = int(sched.tail[i]), tm.grid.fields.to(int(tm.goal[i]))
            for v in tm.grid.neighbours[here]:
                k = int(sched.at[v])
                if field[v] < field[here] and k >= 0 and k != i:
                    edges.append((i, k))
    return edges
