"""Deterministic grid planners on the inflated costmap: 8-connected A* and Theta* (any-angle).

The search runs over cell centres of `costmap.free_mask` (padded with a blocked border so no bounds
checks are needed in the inner loop). Diagonal moves never cut a blocked corner, and a Theta*
line-of-sight requires every cell the segment touches to be free, so paths are as safe as the mask.
Ties break on the smaller heuristic, then the cell index: the same query always gives the same path.
"""

from __future__ import annotations

import heapq
import math
import time
from typing import ClassVar

import numpy as np
from scipy.ndimage import distance_transform_edt

from planning.global_planners.common import (
    attach_endpoints,
    cell_of,
    check_endpoint,
    check_reachable,
    drop_collinear,
    make_result,
)
from planning.global_planners.cost_to_go import cost_to_go
from planning.types import Costmap, PlanResult
from sim.errors import ErrorCode, FleetError
from sim.types import Pose2D

SQRT2 = math.sqrt(2.0)


class _Padded:
    """The free mask as a flat bytes object with a one-cell blocked border, cached per costmap version."""

    _cache: ClassVar[dict[int, tuple[int, _Padded]]] = {}

    def __init__(self, free: np.ndarray) -> None:
        h, w = free.shape
        self.w = w + 2
        padded = np.zeros((h + 2, w + 2), dtype=np.uint8)
        padded[1:-1, 1:-1] = free
        self.free = padded.tobytes()
        # Safe jump length per cell for line-of-sight "sphere tracing": every cell whose centre is closer
        # than the EDT value is free; a jump of L from any point of the cell stays within L + √2 of its centre.
        self.jump = (distance_transform_edt(padded) - SQRT2 - 1e-6).ravel().tolist()

    @classmethod
    def of(cls, costmap: Costmap) -> _Padded:
        hit = cls._cache.get(id(costmap))
        if hit is None or hit[0] != costmap.version:
            if len(cls._cache) > 16:
                cls._cache.clear()
            hit = (costmap.version, cls(costmap.free_mask))
            cls._cache[id(costmap)] = hit
        return hit[1]

    def index(self, rc: tuple[int, int]) -> int:
        return (rc[0] + 1) * self.w + rc[1] + 1

    def cell(self, i: int) -> tuple[int, int]:
        r, c = divmod(i, self.w)
        return r - 1, c - 1

    def line_of_sight(self, a: int, b: int) -> bool:
        """Every cell the segment between the centres of a and b touches is free (corners count both).

        An exact supercover walk, which jumps ahead through open space using the distance field.
        """
        free, w, jump = self.free, self.w, self.jump
        ra, ca = divmod(a, w)
        rb, cb = divmod(b, w)
        nx, ny = abs(cb - ca), abs(rb - ra)
        sx = 1 if cb > ca else -1
        sy = w if rb > ra else -w
        length = math.hypot(nx, ny)
        i = a
        ix = iy = 0
        t = 0.0  # line parameter of a point of the segment inside cell i
        while ix < nx or iy < ny:
            if jump[i] >= 1.0:
                t += jump[i] / length
                if t >= 1.0:
                    return True
                ix, iy = math.floor(t * nx + 0.5), math.floor(t * ny + 0.5)
                i = a + ix * sx + iy * sy
                continue
            decision = (1 + 2 * ix) * ny - (1 + 2 * iy) * nx
            if decision == 0:  # exactly through a corner: both side cells must be free
                if not (free[i + sx] and free[i + sy]):
                    return False
                i += sx + sy
                ix += 1
                iy += 1
                t = (ix - 0.5) / nx
            elif decision < 0:
                i += sx
                ix += 1
                t = (ix - 0.5) / nx
            else:
                i += sy
                iy += 1
                t = (iy - 0.5) / ny
            if not free[i]:
                return False
        return True


def _search(grid: _Padded, s: int, g: int, any_angle: bool,
            guide: list[float] | None = None) -> tuple[list[int], int]:
    """A* (octile heuristic) or Lazy Theta* (Euclidean heuristic, or `guide`: a per-cell heuristic in
    the padded layout). Returns (cell path, expansions).

    Lazy Theta* (Nash, Koenig & Tovey, AAAI 2010) assumes a neighbour sees its grandparent when it is
    generated and checks that line of sight once, when the neighbour is expanded; if it fails, the
    neighbour takes the best expanded grid neighbour as parent. One check per expansion instead of eight.
    """
    w, free = grid.w, grid.free
    gr, gc = divmod(g, w)
    # (offset, step, side a, side b): a diagonal needs both orthogonal side cells free (no corner cutting)
    moves = [(1, 1.0, 0, 0), (-1, 1.0, 0, 0), (w, 1.0, 0, 0), (-w, 1.0, 0, 0),
             (w + 1, SQRT2, w, 1), (w - 1, SQRT2, w, -1), (-w + 1, SQRT2, -w, 1), (-w - 1, SQRT2, -w, -1)]
    hypot = math.hypot

    def heur(i: int) -> float:
        if guide is not None:
            return guide[i]
        r, c = divmod(i, w)
        dx, dy = abs(c - gc), abs(r - gr)
        if any_angle:
            return hypot(dx, dy)
        return dx + dy + (SQRT2 - 2.0) * min(dx, dy)

    cost = {s: 0.0}
    parent = {s: s}
    closed = bytearray(len(free))
    h0 = heur(s)
    heap = [(h0, h0, s)]
    expansions = 0
    found = False
    los = grid.line_of_sight
    while heap:
        _, _, i = heapq.heappop(heap)
        if closed[i]:
            continue
        if any_angle and parent[i] != i and not los(parent[i], i):
            _repair_parent(i, moves, free, closed, cost, parent)
        if i == g:
            found = True
            break
        closed[i] = 1
        expansions += 1
        if any_angle:
            pi = parent[i]
            rp, cp = divmod(pi, w)
            gp = cost[pi]
        else:
            gi = cost[i]
        for d, step, sa, sb in moves:
            j = i + d
            if not free[j] or closed[j] or not (free[i + sa] and free[i + sb]):
                continue
            if any_angle:
                rj, cj = divmod(j, w)
                ng = gp + hypot(rj - rp, cj - cp)
                par = pi
            else:
                ng = gi + step
                par = i
            if ng < cost.get(j, math.inf) - 1e-12:
                cost[j] = ng
                parent[j] = par
                hj = heur(j)
                heapq.heappush(heap, (ng + hj, hj, j))
    if not found:
        return [], expansions
    path = [g]
    while path[-1] != s:
        path.append(parent[path[-1]])
    return path[::-1], expansions


def _repair_parent(i: int, moves: list[tuple[int, float, int, int]], free: bytes, closed: bytearray,
                   cost: dict[int, float], parent: dict[int, int]) -> None:
    """Lazy Theta*'s SetVertex: no line of sight to the assumed parent, so take the best expanded
    neighbour (there is one: the cell that generated i)."""
    best, best_cost = -1, math.inf
    for d, step, sa, sb in moves:
        k = i - d
        if closed[k] and free[i - d + sa] and free[i - d + sb]:
            c = cost[k] + step
            if c < best_cost:
                best, best_cost = k, c
    parent[i] = best
    cost[i] = best_cost


class GridPlanner:
    """8-connected A* (`any_angle=False`) or Theta* (`any_angle=True`) on the costmap's free cells.

    `guided=True` (Theta* only) replaces the Euclidean heuristic by the exact 8-connected cost-to-go
    from one C Dijkstra: far fewer expansions in mazes, at the price of strict optimality (the grid
    distance overestimates the any-angle one by up to about 8 %; measured excess length ≤ 3 %).
    """

    def __init__(self, *, any_angle: bool = False, guided: bool = False, name: str | None = None) -> None:
        self.any_angle = any_angle
        self.guided = guided and any_angle
        self.name = name or ("guided_theta_star" if self.guided else "theta_star" if any_angle else "astar")

    def plan(self, start: Pose2D, goal: Pose2D, costmap: Costmap) -> PlanResult:
        t0 = time.perf_counter()
        s_rc = check_endpoint(costmap, start, "start")
        g_rc = check_endpoint(costmap, goal, "goal")
        check_reachable(costmap, s_rc, g_rc)
        grid = _Padded.of(costmap)
        guide = None
        if self.guided:
            padded = np.full((costmap.free_mask.shape[0] + 2, grid.w), math.inf)
            padded[1:-1, 1:-1] = cost_to_go(costmap, g_rc)
            guide = padded.ravel().tolist()
        cells, expansions = _search(grid, grid.index(s_rc), grid.index(g_rc), self.any_angle, guide)
        if not cells:  # unreachable although connected cannot happen; keep the error honest anyway
            raise FleetError(ErrorCode.PLANNING_FAILED, "no path: the grid search exhausted the free space",
                             "the goal is not reachable from the start")
        rc = np.array([grid.cell(i) for i in cells])
        xmin, ymin, _, _ = costmap.bounds
        res = costmap.resolution
        xy = np.column_stack([xmin + (rc[:, 1] + 0.5) * res, ymin + (rc[:, 0] + 0.5) * res])
        path = drop_collinear(attach_endpoints(costmap, xy, start, goal))
        return make_result(path, start, goal, self.name, time.perf_counter() - t0, expansions)


__all__ = ["GridPlanner", "cell_of"]
