"""Lanes ("highways" in lifelong MAPF): a preferred direction for every row and column of the traffic grid.

When robots use both cells of a two-wide aisle in both directions they meet head-on in each lane, and PIBT
pushes the lower-priority one back, cell after cell (the long waits of the 100-robot warehouse runs,
docs/benchmarks-fleet.md). With moves against a lane's direction costing more, robots keep to the lane of
their direction as on a road, and mostly meet robots going their way, whom a push moves on, not back.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import shortest_path

from planning.distance_fields import DistanceFields


def highways(adjacency: csr_matrix, ij: np.ndarray, against: float) -> csr_matrix:
    """The adjacency with every move against its lane's direction costing `against` times more: rows of even
    y run +x and odd ones -x, columns of even x run +y and odd ones -y, so a two-wide aisle has one lane each
    way and a one-lane aisle a preferred way. Soft: every move stays possible (dead ends, goals, pushes)."""
    coo = adjacency.tocoo()
    d = ij[coo.col] - ij[coo.row]
    horizontal = d[:, 0] != 0
    lane_sign = np.where(horizontal, 1 - 2 * (ij[coo.row, 1] % 2), 1 - 2 * (ij[coo.row, 0] % 2))
    step = np.where(horizontal, d[:, 0], d[:, 1])
    cost = np.where(step * lane_sign < 0, coo.data * against, coo.data)
    return csr_matrix((cost, (coo.row, coo.col)), shape=adjacency.shape)


class DirectedFields(DistanceFields):
    """Cost-to-go fields on a directed graph: distance from every node to a goal along the edges' directions,
    cached per goal (planning.distance_fields.DistanceFields' cache, over the reversed edges)."""

    def __init__(self, adjacency: csr_matrix, capacity: int = 4096) -> None:
        super().__init__(adjacency, capacity)
        self._reverse = csr_matrix(adjacency.T)  # distances *to* a goal = from it over reversed edges

    def _compute(self, goal: int) -> np.ndarray:
        return shortest_path(self._reverse, indices=goal, directed=True)


def corridors(adjacency: csr_matrix) -> list[list[int]]:
    """The one-lane corridors that are not dead ends: maximal chains of two or more cells with at most two
    neighbours each, listed from one end to the other, whose two ends lead to two cells outside the chain that are
    not neighbours (a single narrow cell is a short pass, left two-way)."""
    adj = adjacency.tocsr()
    nb = [adj.indices[adj.indptr[v]:adj.indptr[v + 1]].tolist() for v in range(adj.shape[0])]
    narrow = {v for v in range(len(nb)) if len(nb[v]) <= 2}
    seen: set[int] = set()
    out: list[list[int]] = []
    for s in sorted(narrow):
        if s in seen:
            continue
        comp, stack = [], [s]  # the chain through s (cells of degree ≤ 2 form paths or rings)
        seen.add(s)
        while stack:
            v = stack.pop()
            comp.append(v)
            for u in nb[v]:
                if u in narrow and u not in seen:
                    seen.add(u)
                    stack.append(u)
        ends = [v for v in comp if sum(u in narrow for u in nb[v]) <= 1]
        if not ends:
            continue  # a ring of one-lane cells: no ends to enter by
        chain, prev = [ends[0]], -1
        while True:  # walk the chain from one end
            nxt = [u for u in nb[chain[-1]] if u in narrow and u != prev and u not in chain]
            if not nxt:
                break
            prev = chain[-1]
            chain.append(nxt[0])
        outside = [u for u in nb[chain[0]] if u not in narrow] + (
            [u for u in nb[chain[-1]] if u not in narrow] if len(chain) > 1 else [])
        # A through corridor: two distinct ways out, not next to each other (a dead end has one; two corner cells
        # of a two-wide room lead back beside where they were entered: a bulge, not a corridor).
        if len(chain) > 1 and len(outside) == 2 and outside[0] != outside[1] and outside[1] not in nb[outside[0]]:
            out.append(chain)
    return out


def _orient(adjacency: csr_matrix, chain: list[int], forward: bool) -> csr_matrix:
    """The adjacency with the moves against `chain`'s direction (first → last if `forward`) removed, on the
    chain and at its two mouths (no entry by the exit, no exit by the entry). Edits a copy of the CSR arrays
    (O(edges) in numpy: converting to a row-list matrix per corridor took seconds on maps with hundreds)."""
    c = chain if forward else chain[::-1]
    out = adjacency.copy()
    ptr, idx, data = out.indptr, out.indices, out.data

    def cut(row: int, cols: list[int]) -> None:
        lo, hi = ptr[row], ptr[row + 1]
        data[lo:hi][np.isin(idx[lo:hi], cols)] = 0.0

    inner = set(c)
    for k in range(len(c) - 1):
        cut(c[k + 1], [c[k]])
    cut(c[0], [u for u in idx[ptr[c[0]]:ptr[c[0] + 1]].tolist() if u not in inner])  # the entry does not lead out
    for u in idx[ptr[c[-1]]:ptr[c[-1] + 1]].tolist():
        if u not in inner:
            cut(u, [c[-1]])  # the exit cell is not entered from outside
    out.eliminate_zeros()
    return out


def one_way(adjacency: csr_matrix, ij: np.ndarray) -> tuple[csr_matrix, list[list[int]]]:
    """One-lane through corridors made one-way (as real warehouses sign them), each where the directed graph keeps
    as many strongly connected components as before (every cell still reaches every cell it reached); a corridor
    whose both orientations would cut the graph stays two-way. The direction tried first is the lane's of
    `highways` (rows of even y run +x, columns of even x run +y, by the chain's first step). Returns the
    adjacency and the chains made one-way, each listed in its direction of travel."""
    from scipy.sparse.csgraph import connected_components

    want = connected_components(adjacency, directed=True, connection="strong")[0]
    done: list[list[int]] = []
    for chain in corridors(adjacency):
        d = ij[chain[1]] - ij[chain[0]]
        lane = 1 - 2 * (ij[chain[0], 1] % 2) if d[0] != 0 else 1 - 2 * (ij[chain[0], 0] % 2)
        first = bool((d[0] + d[1]) * lane > 0)
        for forward in (first, not first):
            trial = _orient(adjacency, chain, forward)
            if connected_components(trial, directed=True, connection="strong")[0] == want:
                adjacency = trial
                done.append(chain if forward else chain[::-1])
                break
    return adjacency, done
