"""Is a world a maze? The shortest collision-free start→goal path for a robot of a given radius, against the
straight line between them, judged on the world's geometry (not on names or counts of walls).

The world is rasterised at robot height, grown by the robot's radius, and searched with Dijkstra over a
16-connected grid (steps to the 8 neighbours and the 8 knight moves), whose paths are at most ~2.7 % longer
than the true any-angle shortest path: small against the 20 % a maze must add.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from planning.rasterize import rasterize_world
from sim.types import Pose2D, WorldDescription

MOVES = [(dr, dc) for dr in (-2, -1, 0, 1, 2) for dc in (-2, -1, 0, 1, 2)
         if (dr, dc) != (0, 0) and math.gcd(abs(dr), abs(dc)) == 1]


@dataclass(frozen=True)
class PathCheck:
    straight: float  # m
    shortest: float  # m; inf when the goal cannot be reached
    start_free: bool
    goal_free: bool

    @property
    def reachable(self) -> bool:
        return math.isfinite(self.shortest)

    @property
    def ratio(self) -> float:
        return self.shortest / self.straight if self.straight > 0 else math.inf


def shortest_path(desc: WorldDescription, start: Pose2D, goal: Pose2D, *, robot_radius: float,
                  resolution: float = 0.05) -> PathCheck:
    x0, y0, x1, y1 = desc.bounds(margin=1.0)
    bounds = (min(x0, start.x, goal.x) - 1, min(y0, start.y, goal.y) - 1,
              max(x1, start.x, goal.x) + 1, max(y1, start.y, goal.y) + 1)
    grid = rasterize_world(desc, resolution=resolution, bounds=bounds)
    occupied = grid.data > 0
    r_cells = robot_radius / grid.resolution
    yy, xx = np.mgrid[-math.ceil(r_cells):math.ceil(r_cells) + 1, -math.ceil(r_cells):math.ceil(r_cells) + 1]
    blocked = ndimage.binary_dilation(occupied, structure=(xx**2 + yy**2) <= r_cells**2)
    s, g = grid.world_to_cell(start.x, start.y), grid.world_to_cell(goal.x, goal.y)
    straight = math.hypot(goal.x - start.x, goal.y - start.y)
    start_free, goal_free = not blocked[s], not blocked[g]
    if not (start_free and goal_free):
        return PathCheck(straight, math.inf, start_free, goal_free)
    rows, cols = blocked.shape
    idx = np.arange(rows * cols).reshape(rows, cols)
    src, dst, cost = [], [], []
    free = ~blocked
    for dr, dc in MOVES:
        # Pairs (a, a + move) of free cells; the dilation by the robot radius makes corner cutting harmless.
        a = free[max(0, -dr):rows - max(0, dr), max(0, -dc):cols - max(0, dc)]
        b = free[max(0, dr):rows - max(0, -dr) or None, max(0, dc):cols - max(0, -dc) or None]
        ok = a & b
        ia = idx[max(0, -dr):rows - max(0, dr), max(0, -dc):cols - max(0, dc)][ok]
        ib = idx[max(0, dr):rows - max(0, -dr) or None, max(0, dc):cols - max(0, -dc) or None][ok]
        src.append(ia)
        dst.append(ib)
        cost.append(np.full(ia.size, math.hypot(dr, dc) * grid.resolution))
    n = rows * cols
    graph = coo_matrix((np.concatenate(cost), (np.concatenate(src), np.concatenate(dst))), shape=(n, n)).tocsr()
    dist = dijkstra(graph, indices=int(idx[s]))
    return PathCheck(straight, float(dist[idx[g]]), True, True)
