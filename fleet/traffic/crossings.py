"""Crossings kept clear ("do not block the box", the road rule): where aisles of two or more lanes cross, the 2 × 2
block of crossing cells carries lanes that turn one way round it, and the layer plans no loop of robots following
each other (pibt.py), so a full block moves only when a robot leaves it. A robot that enters a crossing with no way
out towards its goal stands there and blocks both streams; the warehouse's long waits begin at these crossings
(docs/benchmarks-fleet.md, thirteenth landing). So PIBT lets a robot planning its own move (not pushed, not urgent)
enter a crossing cell from outside only when some neighbour of that cell closer to its goal is free in the step
being planned (pibt.py `_has_exit`); otherwise it waits outside, where it blocks only its own lane.
Pushed robots must be able to give way and urgent robots keep the right of way, so both are exempt. And a robot
kept out waits at most `keep_clear_s` (4 s, about one cell's drive from rest) at rest: then it is no longer bound
and enters like any robot (`bound_robots`). Without that limit a robot kept out waited until aging made it urgent
(10 s), in an aisle that the robots parked and held at 300 robots also use, and the rule lengthened the 300-robot
warehouse's longest waits while it shortened the 100-robot ones; with it, it shortens both (docs/benchmarks-fleet.md,
fourteenth landing). On by default (`keep_clear`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from fleet.traffic.admission import held_mask
from fleet.traffic.schedule import BIG

if TYPE_CHECKING:
    from fleet.traffic.manager import TrafficManager


def crossing_cells(ij: np.ndarray, neighbours: list[list[int]]) -> set[int]:
    """Cells with four free neighbours and a blocked diagonal: the cells of a crossing (or T-junction) of aisles
    beside the corners of the blocks around it; open floor, whose diagonals are all free, has none."""
    free = {(int(i), int(j)) for i, j in ij.tolist()}
    out: set[int] = set()
    for v, (i, j) in enumerate(ij.tolist()):
        if len(set(neighbours[v])) == 4 and any((i + dx, j + dy) not in free for dx in (-1, 1) for dy in (-1, 1)):
            out.add(v)
    return out


def bound_robots(tm: TrafficManager, now: float, held: np.ndarray | None = None) -> np.ndarray:
    """The robots the rule binds: those with a goal, and those held by admission on their way to a parking cell
    (admitted in turn, they get a goal), except those at rest with nothing queued for `keep_clear_s` or longer (kept
    out that long, they enter). Not idle robots going back to their cells: three of them shuffled for ever beside a
    crossing in a small test when bound; binding the held robots too is what gives the rule its effect at 100
    robots (docs/benchmarks-fleet.md, thirteenth landing). `held`: admission.held_mask, if the caller has it."""
    bound = tm.pending | (held_mask(tm) if held is None else held)
    nothing_queued = tm.sched.head_step >= BIG  # kept by the schedule (its `queued` would walk every queue again)
    waited = (tm.a == tm.b) & nothing_queued & (now - tm.rest_at >= tm.keep_clear_s)
    return bound & ~waited
