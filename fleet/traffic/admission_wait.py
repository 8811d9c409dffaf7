"""Admission driven by the wait bound itself (the traffic layer's `admission: bound`; docs/benchmarks-fleet.md,
helper 17x).

`park`'s AIMD limit (admission.py) reacts to the *share* of active robots in a wait: one robot whose wait nears the
bound moves that share by 1/active, so the long wait that breaks the bound is invisible to it, and cutting the
limit only adds held robots, which obstruct the lanes too (17k). `bound` keeps `park`'s limit and parking and
adds the wait itself as a signal, locally: a robot *starved* (no closer to its goal for `starve_s`, half the
layer's `stall_s`: half-way to a wait opening, so the protection starts before the wait does) protects the next
`reach` cells of its way to its goal (the static lane field's descent from its planned tail), and a held goal
whose own first `reach` cells cross them is not started while it starves: it keeps its place in the FIFO and the
next held goal that does not cross is started instead.
So no robot is added to the lanes a waiting robot still has to pass, while goals elsewhere keep starting (a global
freeze or cut idles the whole fleet for one merge; measured worse, docs).

`reach` = the cells a robot covers at the layer's peak speed in the time left between starving and the bound
(`bound_s` − `starve_s`): a robot admitted farther away than that cannot reach the waiting robot's way before the
wait must be over.

The limit is fixed: a tenth of the free cells (BOUND_DENSITY), not `park`'s AIMD limit. Over the issue's 10 sim-
minutes the AIMD's growth while the share signal stays low let the active robots drift up (to 121–139 on the
warehouse), and the tail with them; with the flush (`withdraw: crowded`, the layer's default: a re-plan every second
while goals are held, so nothing waits behind stale moves) a fixed tenth of the cells kept 3 of 4 seeds within 30 s
where the adaptive limit kept 1 (docs/benchmarks-fleet.md, eleventh landing). Cutting it was measured worse in the
tenth landing (held robots obstruct too), and below a tenth the waits grow again (77 active robots: as long as at
121).
Nothing depends on the map: the bound, the layer's stall_s and speed, the free cells and the lane field.
A fleet below the limit never holds a goal, so nothing changes for it.

The same protection covers the held robots themselves (`held_clear`, on by default): a held robot on its way to
its parking cell plans no move of its own into a hot cell (`held_off_ways`, pibt.py `keep_off`). At 300 robots the
held robots drive about as much as the active ones (on the warehouse, 85 of 203 held robots are moving at any
time, against 87 of 97 active: trips to parking cells and back after a push), so they too crowd the lanes a
waiting robot still has to pass. A held robot can still be pushed into a hot cell and may leave one, so no push
chain loses a way it had. Over 10 sim-minutes it cut the waits over 25 s by a fifth at 300 robots and a third at
100, at the same throughput, without changing how many seeds keep every wait within 30 s (docs/benchmarks-fleet.md,
fifteenth landing).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from fleet.traffic.admission import Admission, Held, held_mask

if TYPE_CHECKING:
    from fleet.traffic.manager import TrafficManager

WAIT_BOUND_S = 30.0  # every wait resolved within this (issue 17)
BOUND_DENSITY = 0.10  # the fixed limit: active robots per free cell (module doc)


def way(neighbours: list[list[int]], to_goal: np.ndarray, start: int, reach: int) -> list[int]:
    """The first `reach` cells after `start` along the steepest descent of `to_goal` (fewer at the goal)."""
    out, here = [], start
    for _ in range(reach):
        nxt = min(neighbours[here], key=to_goal.__getitem__, default=here)
        if not to_goal[nxt] < to_goal[here]:
            break
        out.append(nxt)
        here = nxt
    return out


@dataclass
class BoundAdmission(Admission):
    """A fixed limit, and held goals that would cross a starved robot's way kept held (module doc)."""

    starve_s: float = 5.0  # a robot this long without coming closer protects its way (the layer: stall_s / 2)
    hot: set[int] = field(default_factory=set)  # cells on the starved robots' ways (set by the layer every tick)
    crosses: Callable[[Held], Iterable[int]] | None = None  # a held goal's first cells (set by the layer)
    _ways: dict[tuple[int, float, float], list[int]] = field(default_factory=dict)  # (tail, goal x, y) -> way

    def update(self, now: float, active: int, stalled: int) -> None:
        """No AIMD step: the limit stays where the layer set it (a tenth of the free cells)."""

    def observe(self, tm: TrafficManager, now: float) -> None:
        """Mark the starved robots' ways hot and let held goals be checked against them (their way from the
        robot's planned tail to the held goal)."""
        if not self.queue:  # nothing held, nothing to keep off (a fleet that flows pays nothing)
            self.hot.clear()
            return
        starved = np.flatnonzero(tm.pending & (now - tm.best_at >= self.starve_s)).tolist()
        reach = reach_cells(self.starve_s, tm.peak)
        nb, fields = tm.grid.neighbours, tm.grid.fields.to
        mark_hot(self, nb, fields, ((int(tm.sched.tail[i]), int(tm.goal[i])) for i in starved), reach)

        if len(self._ways) > 8192:  # held robots' tails and goals change slowly: a small cache of their ways
            self._ways.clear()

        def crosses(h: Held) -> list[int]:
            key = (int(tm.sched.tail[tm._idx[h.robot]]), h.x, h.y)
            if key not in self._ways:
                self._ways[key] = way(nb, fields(tm._goal_node(h.robot, h.x, h.y)), key[0], reach)
            return self._ways[key]

        self.crosses = crosses

    def keeps(self, h: Held) -> bool:
        """A held goal whose own way crosses a hot cell stays held while the robot on that way starves."""
        if not self.hot or self.crosses is None or self.hot.isdisjoint(self.crosses(h)):
            return False
        self.stats["deferred"] = self.stats.get("deferred", 0) + 1
        return True


def mark_hot(adm: BoundAdmission, neighbours: list[list[int]], fields: Callable[[int], np.ndarray],
             starved: Iterable[tuple[int, int]], reach: int) -> None:
    """The hot cells: the next `reach` cells of every starved robot's way ((planned tail, goal) pairs)."""
    adm.hot.clear()
    for tail, goal in starved:
        adm.hot.update(way(neighbours, fields(goal), tail, reach))


def reach_cells(starve_s: float, peak: float, bound_s: float = WAIT_BOUND_S) -> int:
    """Cells covered at `peak` cells/s between a robot starving and the bound."""
    return max(1, math.ceil(peak * max(bound_s - starve_s, 0.0)))


def held_off_ways(tm: TrafficManager, held: np.ndarray | None = None) -> tuple[np.ndarray | None, set[int]]:
    """The held robots (PIBT's `keep_off` mask; `held`: admission.held_mask, if the caller has it) and the hot cells
    they keep off on their own moves (module doc); (None, empty) when nothing is held or no robot starves."""
    adm = tm.admission
    if not isinstance(adm, BoundAdmission) or not adm.hot or not adm.queue:
        return None, set()
    return (held_mask(tm) if held is None else held), adm.hot
