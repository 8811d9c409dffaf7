"""Waypoint following on top of the navigator: a sequence once, a loop, or a patrol, each waypoint with an
optional dwell (sim time spent stopped on arrival).

Modes (`rounds` counts full passes):
- sequence: 0, 1, …, n-1 once;
- loop: 0 … n-1, 0 … n-1, … for `rounds` rounds (None: until canceled);
- patrol: there and back, 0 … n-1 … 1 (the turning points visited once per pass) for `rounds` rounds
  (None: until canceled); the last round ends back at waypoint 0.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import Literal

from planning.nav_types import NavState, Waypoint, WaypointStatus, WaypointVisit
from planning.navigator import STOP, Navigator
from sim.errors import ErrorCode, FleetError
from sim.types import LidarScan, Pose2D

WaypointMode = Literal["sequence", "loop", "patrol"]


def visit_order(n: int, mode: WaypointMode, rounds: int | None) -> Iterator[tuple[int, int]]:
    """(waypoint index, round) in visiting order; endless when rounds is None (loop/patrol)."""
    if mode == "sequence":
        rounds = 1
    one_round = list(range(n)) + (list(range(n - 2, 0, -1)) if mode == "patrol" else [])
    r = 0
    while rounds is None or r < rounds:
        for i in one_round:
            yield i, r
        r += 1
    if mode == "patrol" and n > 1:
        yield 0, r - 1  # the last patrol round ends back at the start


class WaypointFollower:
    """Drives a Navigator through waypoints; tick it like the navigator: `tick(now, pose, twist, scan)`."""

    def __init__(self, *, navigator: Navigator, waypoints: Sequence[Waypoint], mode: WaypointMode = "sequence",
                 rounds: int | None = 1, skip_failed: bool = False) -> None:
        if not waypoints:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, "no waypoints given", "pass at least one waypoint")
        if mode not in ("sequence", "loop", "patrol"):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"unknown waypoint mode '{mode}'",
                             "modes: loop, patrol, sequence")
        if rounds is not None and rounds < 1:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"rounds must be >= 1 or null, got {rounds}",
                             "use null to repeat until canceled")
        if any(w.dwell_s < 0 for w in waypoints):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, "dwell_s must be >= 0", "use 0 for no dwell")
        self.nav, self.waypoints, self.mode, self.rounds = navigator, list(waypoints), mode, rounds
        self.skip_failed = skip_failed
        self._state, self._reason = NavState.IDLE, ""
        self._visits: list[WaypointVisit] = []
        self._dwell_until: float | None = None
        self._index, self._round = 0, 0
        self._order: Iterator[tuple[int, int]] = iter(())

    def start(self, now: float) -> None:
        self._order = visit_order(len(self.waypoints), self.mode, self.rounds)
        self._visits, self._dwell_until = [], None
        self._state, self._reason = NavState.TRACKING, ""
        self._next(now)

    def cancel(self) -> None:
        if self._state is not NavState.IDLE and not self._state.done:
            self.nav.cancel()
            self._state, self._reason = NavState.CANCELED, "canceled by the caller"

    def tick(self, now: float, pose: Pose2D, twist: tuple[float, float],
             scan: LidarScan | None) -> tuple[float, float]:
        if self._state is NavState.IDLE or self._state.done:
            return STOP
        if self._dwell_until is not None:  # 1. dwelling at a waypoint: stay stopped until the time is up
            if now < self._dwell_until:
                return STOP
            self._dwell_until = None
            self._next(now)
            return STOP if self._state.done else self.nav.tick(now, pose, twist, scan)
        cmd = self.nav.tick(now, pose, twist, scan)  # 2. drive the current leg
        leg = self.nav.state
        if leg is NavState.SUCCEEDED:  # 3. arrived: record the visit, dwell or move on
            self._visits.append(WaypointVisit(self._index, self._round, now, pose))
            dwell = self.waypoints[self._index].dwell_s
            if dwell > 0:
                self._dwell_until = now + dwell
            else:
                self._next(now)
            return STOP
        if leg is NavState.FAILED:
            reason = f"waypoint {self._index} (round {self._round}): {self.nav.status().reason}"
            if not self.skip_failed:
                self._state, self._reason = NavState.FAILED, reason
                return STOP
            self._reason = f"skipped {reason}"
            self._next(now)
            return STOP
        return cmd

    def status(self, now: float | None = None) -> WaypointStatus:
        return WaypointStatus(state=self._state, reason=self._reason, current_index=self._index,
                              current_round=self._round, visits=tuple(self._visits),
                              dwelling=self._dwell_until is not None,
                              leg=self.nav.status(now) if self._state is not NavState.IDLE else None)

    @property
    def state(self) -> NavState:
        return self._state

    def _next(self, now: float) -> None:
        nxt = next(self._order, None)
        if nxt is None:
            self._state = NavState.SUCCEEDED
            return
        self._index, self._round = nxt
        wp = self.waypoints[self._index]
        self.nav.set_goal(wp.pose, now, align_yaw=wp.use_yaw)
