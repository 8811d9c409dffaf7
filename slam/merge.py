"""Merge several robots' occupancy maps into one, given where each map frame sits in the common frame.

Every source cell becomes evidence (occupied +2, free −1, unknown 0), sampled at the common grid's
cell centres through the inverse transform (nearest cell), and summed. A cell one robot saw occupied
and another free stays occupied: for planning, a missed obstacle is worse than a missed free cell.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from planning.grid import FREE_CELL, OCCUPIED, UNKNOWN_CELL, OccupancyGrid
from sim.errors import ErrorCode, FleetError
from sim.types import Pose2D
from slam import se2

_OCC_EVIDENCE, _FREE_EVIDENCE = 2.0, -1.0


def merge_maps(maps: Sequence[tuple[OccupancyGrid, Pose2D]], resolution: float | None = None) -> OccupancyGrid:
    """`maps`: (grid, pose of that grid's map frame in the common frame). Resolution defaults to the finest."""
    if not maps:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, "nothing to merge", "pass at least one (grid, pose) pair")
    res = resolution or min(g.resolution for g, _ in maps)
    corners = []
    for g, pose in maps:
        x0, y0, x1, y1 = g.bounds
        c = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
        corners.append(se2.transform_points(pose.as_tuple(), c))
    allc = np.vstack(corners)
    # Keep the first map's cell lattice (its frame is usually the common one): its cells map 1:1.
    ref = np.array(maps[0][0].origin)
    lo = ref + np.floor((allc.min(axis=0) - ref) / res + 1e-9) * res
    n = np.ceil((allc.max(axis=0) - lo) / res - 1e-9).astype(int)
    out = OccupancyGrid(np.full((n[1], n[0]), UNKNOWN_CELL, dtype=np.int8), res, (float(lo[0]), float(lo[1])))
    xs, ys = out.cell_centres()
    centres = np.column_stack([xs.ravel(), ys.ravel()])
    evidence = np.zeros(len(centres))
    for g, pose in maps:
        inv = se2.from_matrix(np.linalg.inv(se2.to_matrix(pose.as_tuple())))
        local = se2.transform_points(inv, centres)
        rows, cols = g.world_to_cells(local)
        ok = g.in_bounds_many(rows, cols)
        v = np.full(len(centres), UNKNOWN_CELL, dtype=np.int16)
        v[ok] = g.data[rows[ok], cols[ok]]
        evidence += np.where(v >= 65, _OCC_EVIDENCE, np.where((v >= 0) & (v < 20), _FREE_EVIDENCE, 0.0))
    data = np.full(len(centres), UNKNOWN_CELL, dtype=np.int8)
    data[evidence > 0] = OCCUPIED
    data[evidence < 0] = FREE_CELL
    out.data[:] = data.reshape(out.data.shape)
    return out


def relative_pose(a_in_world: Pose2D, b_in_world: Pose2D) -> Pose2D:
    """Pose of map frame b in map frame a, from both frames' poses in a shared frame."""
    x, y, yaw = se2.from_matrix(np.linalg.inv(se2.to_matrix(a_in_world.as_tuple()))
                                @ se2.to_matrix(b_in_world.as_tuple()))
    return Pose2D(x, y, math.atan2(math.sin(yaw), math.cos(yaw)))
