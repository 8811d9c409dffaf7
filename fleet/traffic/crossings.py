"""Crossings kept clear ("do not block the box", the road rule): where aisles of two or more lanes cross, the 2 × 2
block of crossing cells carries lanes that turn one way round it, and the layer plans no loop of robots following
each other (pibt.py), so a full block moves only when a robot leaves it. A robot that enters a crossing with no way
out towards its goal stands there and blocks both streams; the warehouse's long waits begin at these crossings
(docs/benchmarks-fleet.md, thirteenth landing). So PIBT lets a robot planning its own move (not pushed, not urgent)
enter a crossing cell from outside only when some neighbour of that cell closer to its goal is free in the step
being planned (pibt.py `_has_exit`); otherwise it waits outside, where it blocks only its own lane.
Pushed robots must be able to give way and urgent robots keep the right of way, so both are exempt: a robot kept out
(say by an idle robot standing in the crossing's exit, which only a robot inside would push) enters once it has
waited `urgent_s`, so the rule needs aging (settings.py rejects it without), and it binds only robots that will
become urgent if kept out (`bound_robots`); PIBT's guarantee for the highest-priority robot holds once it is
urgent. Opt-in (`keep_clear`, off by default): over 10 sim-minutes it cut the 100-robot warehouse's waits over
25 s by two thirds but made the longest 300-robot ones longer (docs/benchmarks-fleet.md, thirteenth landing)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

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


def bound_robots(tm: TrafficManager) -> np.ndarray:
    """The robots the rule binds: those with a goal, and those held by admission on their way to a parking cell
    (admitted in turn, they get a goal). Not idle robots going back to their cells: they never become urgent, so one
    kept out would stay out (three of them shuffled for ever beside a crossing in a small test); binding the held
    robots too is what gives the rule its effect at 100 robots (docs/benchmarks-fleet.md, thirteenth landing)."""
    bound = tm.pending.copy()
    if tm.admission is not None and tm.admission.queue:
        bound[[tm._idx[h.robot] for h in tm.admission.queue]] = True
    return bound
