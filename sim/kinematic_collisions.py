"""Collision detection *and resolution* for kinematic robots.

Invariant: the poses at the start of a step are collision-free. After integrating, robots are teleported
to their new poses and PyBullet's collision detection is queried; any robot in penetration goes back to
its previous pose (and stops). Since all-previous is collision-free, reverting enough robots always ends
with a collision-free world: robots never pass through each other or obstacles.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pybullet as p
from scipy.spatial import cKDTree

from sim.transforms import rpy_to_quat

RawContact = tuple[int, tuple[float, float, float], float]  # (other uid, position, penetration depth)

if TYPE_CHECKING:
    from sim.world import World

PENETRATION = -1e-3  # m: contact distances below this are overlaps, not grazing contacts


def teleport(world: World, rows: np.ndarray) -> None:
    f, c = world.table.f, world.client
    for i in rows:
        half = 0.5 * float(f["yaw"][i])
        p.resetBasePositionAndOrientation(int(world.table.body[i]), (float(f["x"][i]), float(f["y"][i]), 0.0),
                                          (0.0, 0.0, np.sin(half), np.cos(half)), physicsClientId=c)


def penetrating_contacts(world: World) -> list[tuple[int, int, tuple[float, float, float], float]]:
    """(uid_a, uid_b, position on a, distance) of every penetrating pair, ground contacts excluded."""
    p.performCollisionDetection(physicsClientId=world.client)
    out = []
    ground = world._ground_uids
    for c in p.getContactPoints(physicsClientId=world.client):
        if c[8] < PENETRATION and c[1] not in ground and c[2] not in ground:
            out.append((c[1], c[2], c[5], c[8]))
    return out


def resolve_kinematic_collisions(world: World, moved: np.ndarray,
                                 previous: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
    """Teleport moved robots, revert the ones that penetrate anything. Returns the reverted rows.

    One PyBullet detection pass finds the penetrations. Reverting a robot can uncover an overlap with a
    robot that moved into the spot it left; rather than another full detection pass, those neighbours are
    found with a conservative circle test in numpy and reverted too, until no reverted spot is contested."""
    t = world.table
    f = t.f
    kin_rows = np.flatnonzero(t.b["kinematic"])
    t.b["in_collision"][kin_rows] = False
    for i in kin_rows:
        world._contacts[t.names[i]] = ()
    if moved.size == 0:
        return moved
    teleport(world, moved)
    uid_to_row = {int(t.body[i]): int(i) for i in kin_rows}
    moved_set = {int(r) for r in moved}
    contacts: dict[int, list[RawContact]] = {}
    revert: set[int] = set()
    for a, b, pos, dist in penetrating_contacts(world):
        for uid, other in ((a, b), (b, a)):
            row = uid_to_row.get(uid)
            if row is None:
                continue
            contacts.setdefault(row, []).append((other, pos, -dist))
            if row in moved_set:
                revert.add(row)
    prev_xy = np.full((len(t), 2), np.nan)
    prev_xy[moved] = np.column_stack([previous[0], previous[1]])
    prev_yaw = dict(zip(moved.tolist(), previous[2].tolist(), strict=True))
    reach = 2.0 * f["radius"][kin_rows].max() if kin_rows.size else 0.0
    frontier = set(revert)
    while frontier:
        rows = np.array(sorted(frontier))
        f["x"][rows], f["y"][rows] = prev_xy[rows, 0], prev_xy[rows, 1]
        f["yaw"][rows] = [prev_yaw[int(r)] for r in rows]
        # Moved, not-yet-reverted robots now within two footprint radii of a reverted robot's old spot.
        cand = np.array(sorted(moved_set - revert), dtype=np.int64)
        frontier = set()
        if cand.size:
            tree = cKDTree(np.column_stack([f["x"][cand], f["y"][cand]]))
            near = tree.query_ball_point(np.column_stack([f["x"][rows], f["y"][rows]]), reach)
            frontier = {int(cand[k]) for ks in near for k in ks}
            revert |= frontier
    rows = np.array(sorted(revert), dtype=np.int64)
    teleport(world, rows)
    for row, cs in contacts.items():
        t.b["in_collision"][row] = True
        world._contacts[t.names[row]] = tuple(cs)  # raw: labelled only when someone reads them
    return rows


def overlaps(world: World, uid: int) -> list[str]:
    """Names of everything body `uid` penetrates now (used to refuse spawning or teleporting into things)."""
    p.performCollisionDetection(physicsClientId=world.client)
    names = []
    for c in p.getContactPoints(bodyA=uid, physicsClientId=world.client):
        if c[8] < PENETRATION and c[2] not in world._ground_uids:
            names.append(world.body_label(c[2])[0] or f"body {c[2]}")
    return sorted(set(names))


__all__ = ["overlaps", "resolve_kinematic_collisions", "rpy_to_quat", "teleport"]
