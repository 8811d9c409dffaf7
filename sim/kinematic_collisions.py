"""Collision detection *and resolution* for kinematic robots.

Invariant: the poses at the start of a step are collision-free. After integrating, moved robots are
teleported to their new poses and every candidate pair is measured afresh (sim/contact_query.py); any
robot in penetration goes back to its previous pose (and stops). Since all-previous is collision-free,
reverting enough robots always ends with a collision-free world: robots never pass through each other or
obstacles.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pybullet as p

from sim.contact_broadphase import expand_ranges, hulls
from sim.contact_query import PENETRATION, robot_penetrations

RawContact = tuple[int, tuple[float, float, float], float]  # (other uid, position, penetration depth)

if TYPE_CHECKING:
    from sim.world import World

__all__ = ["PENETRATION", "RawContact", "overlaps", "penetrating_contacts", "resolve_kinematic_collisions",
           "teleport"]


def teleport(world: World, rows: np.ndarray) -> None:
    if rows.size == 0:
        return
    f, c = world.table.f, world.client
    half = 0.5 * f["yaw"][rows]
    args = zip(world.table.body[rows].tolist(), f["x"][rows].tolist(), f["y"][rows].tolist(),
               np.sin(half).tolist(), np.cos(half).tolist(), strict=True)
    reset = p.resetBasePositionAndOrientation
    for uid, x, y, qz, qw in args:  # the client id positional: no keyword parsing in the fleet's hottest loop
        reset(uid, (x, y, 0.0), (0.0, 0.0, qz, qw), c)


def penetrating_contacts(world: World) -> list[tuple[int, int, tuple[float, float, float], float]]:
    """(uid_a, uid_b, position on a, distance) of every penetrating pair involving a robot, measured now."""
    return robot_penetrations(world)


def resolve_kinematic_collisions(world: World, moved: np.ndarray,
                                 previous: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
    """Teleport moved robots, revert the ones that penetrate anything. Returns the reverted rows.

    One PyBullet detection pass finds the penetrations. Reverting a robot can uncover an overlap with a
    robot that moved into the spot it left; rather than another full detection pass, those neighbours are
    found with a conservative circle test in numpy and reverted too, until no reverted spot is contested."""
    t = world.table
    f = t.f
    kin = t.b["kinematic"]
    kin_rows = np.flatnonzero(kin)
    t.b["in_collision"][kin_rows] = False
    # Only robots in contact have an entry (latest_contacts reads a missing one as none): clearing the
    # kinematic ones touches the few in contact, not every robot of the fleet.
    if kin_rows.size == len(t):
        world._contacts.clear()
    else:
        for name in [n for n in world._contacts if kin[t.index(n)]]:
            del world._contacts[name]
    if moved.size == 0:
        return moved
    teleport(world, moved)
    row_of = t.row_of_uid
    contacts: dict[int, list[RawContact]] = {}
    for a, b, pos, dist in robot_penetrations(world, moved):
        for uid, other in ((a, b), (b, a)):
            row = row_of.get(uid)
            if row is not None:
                contacts.setdefault(row, []).append((other, pos, -dist))
    hit = np.fromiter(contacts, dtype=np.int64, count=len(contacts))
    hit = hit[kin[hit]]  # a dynamic robot's contacts come from its own physics
    is_moved = np.zeros(len(t), dtype=bool)
    is_moved[moved] = True
    reverted = np.zeros(len(t), dtype=bool)
    reverted[hit[is_moved[hit]]] = True
    frontier = np.flatnonzero(reverted)
    if frontier.size:
        _revert_cascade(f, moved, previous, reverted, frontier, 2.0 * float(hulls(t).r0[kin_rows].max()))
    rows = np.flatnonzero(reverted)
    teleport(world, rows)
    t.b["in_collision"][hit] = True
    names = t.names
    for row in hit.tolist():
        world._contacts[names[row]] = tuple(contacts[row])  # raw: labelled only when someone reads them
    return rows


def _revert_cascade(f: dict[str, np.ndarray], moved: np.ndarray, previous: tuple[np.ndarray, np.ndarray, np.ndarray],
                    reverted: np.ndarray, frontier: np.ndarray, reach: float) -> None:
    """Put the frontier's robots back, then every moved robot now within `reach` (two circles holding the
    robots' shapes) of a reverted robot's old spot, until no reverted spot is contested. Marks `reverted`."""
    at = np.empty(reverted.size, dtype=np.int64)  # row → its position in `moved` (and in `previous`)
    at[moved] = np.arange(moved.size)
    # Moved robots stay where they moved until reverted, so one sort of them along x serves every round.
    by_x = moved[np.argsort(f["x"][moved], kind="stable")]
    mx, my = f["x"][by_x], f["y"][by_x]
    near = np.zeros(by_x.size, dtype=bool)
    while frontier.size:
        k = at[frontier]
        fx, fy = previous[0][k], previous[1][k]
        f["x"][frontier], f["y"][frontier], f["yaw"][frontier] = fx, fy, previous[2][k]
        owner, j = expand_ranges(np.searchsorted(mx, fx - reach, side="left"),
                                 np.searchsorted(mx, fx + reach, side="right"))
        near[:] = False
        near[j[np.hypot(mx[j] - fx[owner], my[j] - fy[owner]) <= reach]] = True
        hit = by_x[near]
        frontier = hit[~reverted[hit]]
        reverted[frontier] = True


def overlaps(world: World, uid: int) -> list[str]:
    """Names of everything body `uid` (a robot) penetrates now (used to refuse spawning or teleporting into things)."""
    rows = np.flatnonzero(world.table.body == uid)
    names = []
    for a, b, _, _ in robot_penetrations(world, rows):
        other = b if a == uid else a
        names.append(world.body_label(other)[0] or f"body {other}")
    return sorted(set(names))
