"""Fresh, exact penetration queries for robots: a numpy broadphase, then PyBullet's getClosestPoints per pair.

PyBullet's cached contact manifolds can under-report penetration right after teleports (seen in
benchmarks/sim_throughput.py: −0.6 mm reported where getClosestPoints measured −2.2 mm), so kinematic
collision handling measures candidate pairs afresh instead of reading performCollisionDetection's cache.

The broadphase (sim/contact_broadphase.py) is conservative: it never drops a pair getClosestPoints would find
in penetration. A kinematic robot is tested as its collision shapes' bounding box in its own frame
(`hull_columns`, measured once at spawn), so only pairs whose boxes overlap pay the engine query.
"""

from __future__ import annotations

from operator import itemgetter
from typing import TYPE_CHECKING

import numpy as np
import pybullet as p

from sim.contact_broadphase import GROW, boxes_overlap, expand_ranges, robot_robot
from sim.contact_obstacles import moving_pairs, static_pairs

if TYPE_CHECKING:
    from sim.world import World

__all__ = ["GROW", "PENETRATION", "ROBOT_TOP", "boxes_overlap", "candidate_pairs", "expand_ranges", "hull_columns",
           "penetrations", "robot_penetrations"]

PENETRATION = -1e-3  # m: distances below this are overlaps, not grazing contacts
ROBOT_TOP = 0.7  # m: robots' AABB height for the obstacle broadphase (lidar housing included)
Penetration = tuple[int, int, tuple[float, float, float], float]  # uid a, uid b, position on a, distance
by_distance = itemgetter(8)  # a contact point's signed distance


def hull_columns(client: int, uid: int) -> dict[str, float]:
    """The robot table's hull columns of a one-body robot proxy: its collision shapes' bounding rectangle in
    base_link's frame, read as its AABB while it stands unrotated at the origin (where robots are created)."""
    lo, hi = p.getAABB(uid, -1, physicsClientId=client)
    return {"hull_x0": lo[0], "hull_x1": hi[0], "hull_y0": lo[1], "hull_y1": hi[1]}


def candidate_pairs(world: World, rows: np.ndarray) -> list[tuple[int, int]]:
    """Pairs (robot uid, other uid) that might penetrate, for the robots in `rows`: robot pairs whose boxes
    overlap, then static obstacles whose footprint touches a robot's box, then moving models whose axis-aligned
    box does (obstacles only within robot height)."""
    t = world.table
    if rows.size == 0 or len(t) == 0:
        return []
    body = t.body
    pairs: list[tuple[int, int]] = []
    if len(t) > 1:
        in_rows = None
        if rows.size < len(t):
            in_rows = np.zeros(len(t), dtype=bool)
            in_rows[rows] = True
        a, b = robot_robot(t, in_rows)
        pairs += zip(body[a].tolist(), body[b].tolist(), strict=True)
    uids, lo, hi = world.models.static_obstacle_aabbs()
    if uids.size:
        k, j = static_pairs(t, rows, world.models, world.client, uids, lo, hi, ROBOT_TOP)
        pairs += zip(body[k].tolist(), uids[j].tolist(), strict=True)
    uids, lo, hi = world.models.moving_obstacle_aabbs()
    if uids.size:
        k, j = moving_pairs(t, rows, lo, hi, ROBOT_TOP)
        pairs += zip(body[k].tolist(), uids[j].tolist(), strict=True)
    return pairs


def penetrations(world: World, pairs: list[tuple[int, int]]) -> list[Penetration]:
    """The deepest point of every pair in penetration, measured now."""
    out = []
    closest, c = p.getClosestPoints, world.client
    for a, b in pairs:
        pts = closest(a, b, 0.0, physicsClientId=c)
        if not pts:
            continue
        deepest = min(pts, key=by_distance)
        if deepest[8] < PENETRATION:
            pos = deepest[5]
            out.append((a, b, (pos[0], pos[1], pos[2]), float(deepest[8])))
    return out


def robot_penetrations(world: World, rows: np.ndarray | None = None) -> list[Penetration]:
    """Every penetration involving the robots in `rows` (all robots by default)."""
    idx = np.arange(len(world.table)) if rows is None else rows
    return penetrations(world, candidate_pairs(world, idx))
