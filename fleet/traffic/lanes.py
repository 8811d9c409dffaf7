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
