"""Shared cost-to-go fields on a static graph: one distance field per goal (breadth-first on an unweighted
graph, Dijkstra on a weighted one), computed once and cached (LRU), for every robot heading to that goal
(issue 17: not per plan, not per robot)."""

from __future__ import annotations

from collections import OrderedDict

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import shortest_path


class DistanceFields:
    """Distances to a goal node over a fixed graph (CSR adjacency; edge weights are costs, all 1: hops),
    cached per goal."""

    def __init__(self, adjacency: csr_matrix, capacity: int = 4096) -> None:
        self.adjacency = adjacency
        self.unweighted = bool(np.all(adjacency.data == 1.0))
        self.capacity = capacity
        self._cache: OrderedDict[int, np.ndarray] = OrderedDict()
        self.computed = 0  # fields computed (cache misses), for benchmarks

    def to(self, goal: int) -> np.ndarray:
        """Distance from every node to `goal`; inf where unreachable. The graph is undirected, so this is the
        distance from `goal` outward."""
        field = self._cache.get(goal)
        if field is None:
            field = self._compute(goal)
            field.setflags(write=False)
            self._cache[goal] = field
            self.computed += 1
            if len(self._cache) > self.capacity:
                self._cache.popitem(last=False)
        else:
            self._cache.move_to_end(goal)
        return field

    def _compute(self, goal: int) -> np.ndarray:
        return shortest_path(self.adjacency, unweighted=self.unweighted, indices=goal, directed=False)
