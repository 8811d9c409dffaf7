"""Dispatch admission for the traffic layer: new goals are held (FIFO) while the layer is congested.

The layer is a closed queueing network: once the robots with goals saturate a bottleneck (a warehouse's central
aisle), each further active robot adds only queueing there, so waits grow with the fleet and throughput falls
(docs/benchmarks-fleet.md, "fifth landing, helper 17h"). Real fleet managers therefore admit only as many robots
to active tasks as the layout carries; the others stay parked until admitted.

The limit is adapted AIMD-style, as TCP's congestion window is, so it needs no per-map tuning: every `period_s`
the share of active robots in a wait (no progress for the layer's `stall_s`) is compared with `stalled_share`.
Above it the limit drops to `decrease` × min(limit, active) (multiplicative decrease), once per drain: not again
while more robots are active than the last decrease allows, nor within `cooldown_s` (the signal lags by
`stall_s`). Otherwise, while the limit binds, it grows by `grow` robots per period (additive increase); while it
does not bind and nothing is held, it is lifted, so a layer that never congests never holds a goal. Before any
congestion is seen, the layer starts it at 1/8 of its free cells (START_DENSITY), and never below 1 / the
stalled share (the fewest robots on which that share can be measured: 20 for `park`).

`park` (parking.py): held robots wait on parking cells off the main flow instead of where they stand. Parked
robots barely obstruct, so a lower limit costs little: the limit is cut at 5 % of the active robots in a wait
(not 20 %), and grows by one robot per `stall_s` (the signal's lag, as TCP's window grows once per round trip).
So low a share is crossed by the passing waits of a fleet that flows (6 of 100 robots on the warehouse), so `park`
never cuts while nothing is held and the active robots are within the start limit (`free_below`): a fleet below
the start density is never limited (docs/benchmarks-fleet.md, helper 17i: cutting 100 robots cost 7 % of tasks).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from fleet.traffic.manager import TrafficManager

ADMISSION = ("off", "aimd", "park", "bound")  # park: aimd + parking cells (parking.py); bound: admission_wait.py
PARKED = ("park", "bound")  # held robots wait on parking cells
START_DENSITY = 0.125  # robots with goals per free cell before any congestion is seen
# share of the robots with goals in a wait above which the limit is cut
STALLED_SHARE = {"aimd": 0.2, "park": 0.05, "bound": 0.05}


@dataclass
class Held:
    """A goal given to a robot but not yet admitted."""

    robot: str
    x: float
    y: float
    since: float  # sim time it was given


@dataclass
class Admission:
    """The AIMD limit on active robots and the FIFO of held goals (no robots, no map: the layer drives it)."""

    period_s: float = 2.0
    stalled_share: float = 0.2
    decrease: float = 0.7
    grow: int = 1
    cooldown_s: float = 10.0  # no second decrease sooner: the stall signal lags by the layer's stall_s
    grow_s: float = 0.0  # no increase sooner after the last one (park: one robot per signal lag, as TCP per RTT)
    free_below: float = 0.0  # no decrease while nothing is held and at most this many robots are active (park)
    limit: float = math.inf
    queue: deque[Held] = field(default_factory=deque)
    _next: float = 0.0
    _cut: float = -math.inf
    _grown: float = -math.inf
    stats: dict[str, float] = field(default_factory=lambda: {"held": 0, "admitted": 0, "decreases": 0,
                                                              "lowest_limit": math.inf, "longest_hold_s": 0.0})

    def held(self, robot: str) -> bool:
        return any(h.robot == robot for h in self.queue)

    def must_hold(self, active: int) -> bool:
        """A new goal waits when others already wait (FIFO) or the active robots are at the limit."""
        return bool(self.queue) or active >= self.limit

    def hold(self, robot: str, x: float, y: float, now: float) -> None:
        """Queue a goal; a robot has one goal, so a newer one replaces its held one in place."""
        for h in self.queue:
            if h.robot == robot:
                h.x, h.y = x, y
                return
        self.queue.append(Held(robot, x, y, now))
        self.stats["held"] += 1

    def drop(self, robot: str) -> None:
        """The robot's held goal is withdrawn (task cancelled, robot left the layer)."""
        self.queue = deque(h for h in self.queue if h.robot != robot)

    def observe(self, tm: TrafficManager, now: float) -> None:
        """The layer's state this tick, for modes whose admission looks at robots (admission_wait.py)."""

    def update(self, now: float, active: int, stalled: int) -> None:
        """AIMD step, once per period: `active` robots have goals, `stalled` of them are in a wait."""
        if now < self._next:
            return
        self._next = now + self.period_s
        if active > 0 and stalled > self.stalled_share * active and (self.queue or active > self.free_below):
            if active > self.limit or now < self._cut + self.cooldown_s:
                return  # the last decrease has not taken effect yet (robots drain as they arrive): hold it
            self._cut = now
            self.limit = max(1.0, math.floor(self.decrease * min(self.limit, active)))
            self.stats["decreases"] += 1
            self.stats["lowest_limit"] = min(self.stats["lowest_limit"], self.limit)
        elif active >= self.limit - 1 or self.queue:
            if now >= self._grown + self.grow_s:
                self._grown = now
                self.limit += self.grow
        else:
            self.limit = math.inf  # not binding and nobody waiting: no limit

    def keeps(self, h: Held) -> bool:
        """Whether a held goal the limit would start stays held now, in its place (bound: admission_wait.py)."""
        return False

    def admit(self, active: int, now: float) -> list[Held]:
        """The held goals to start now, oldest first, so that active robots stay within the limit; those `keeps`
        holds back stay at the front of the FIFO in their order."""
        out: list[Held] = []
        kept: list[Held] = []
        while self.queue and active + len(out) < self.limit:
            h = self.queue.popleft()
            if self.keeps(h):
                kept.append(h)
                continue
            self.stats["longest_hold_s"] = max(self.stats["longest_hold_s"], now - h.since)
            out.append(h)
        self.queue.extendleft(reversed(kept))
        self.stats["admitted"] += len(out)
        return out


def held_mask(tm: TrafficManager) -> np.ndarray:
    """Per robot of the layer, whether admission holds its goal (all False with admission off or nothing held).
    The layer computes it once per plan for the rules that treat held robots apart (priority.py, crossings.py,
    admission_wait.py)."""
    held = np.zeros(len(tm.names), bool)
    if tm.admission is not None and tm.admission.queue:
        held[[tm._idx[h.robot] for h in tm.admission.queue]] = True
    return held


def layer_admission(mode: str, stall_s: float, cells: int) -> Admission | None:
    """The traffic layer's admission for its `admission` setting (module doc), None when off."""
    if mode == "off":
        return None
    # The stalled share cannot be measured on fewer than 1 / share robots (one wait already exceeds it), so the
    # limit never starts below that: a small map's fleet that flows is never held (the corridor world: 28 cells).
    make: Callable[..., Admission] = Admission
    density = START_DENSITY
    if mode == "bound":  # a fixed limit, and held goals kept off the ways of robots in a wait (admission_wait.py)
        from fleet.traffic.admission_wait import BOUND_DENSITY, BoundAdmission

        density, make = BOUND_DENSITY, partial(BoundAdmission, starve_s=0.5 * stall_s)
    start = max(1.0 / STALLED_SHARE[mode], density * cells)
    park = mode in PARKED
    return make(cooldown_s=stall_s, limit=start, stalled_share=STALLED_SHARE[mode],
                grow_s=stall_s if park else 0.0, free_below=start if park else 0.0)
