"""Lease and rate bookkeeping for the safety envelope (leases: wall clock; rates: sim time).

A lease is renewed by every command of its holder and lapses after `idle_s` without one; front doors that know
when a client is gone (Zenoh liveliness, a closed session) release it at once and mark the client departed, so a
command of that client still in flight cannot take the robot again under a dead id. Rates are counted over a
sliding one-second window of accepted commands (see RateWindow for which clock): per robot (one command per
control tick, with room for jitter) and per client (a ceiling sized for a fleet controller driving every robot).
"""

from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass, field

DEPARTED_MEMORY = 4096  # departed client ids remembered (oldest forgotten first)


@dataclass
class Lease:
    client: str
    idle_s: float  # lapses this long after its last use
    used: float = field(default_factory=time.monotonic)

    @property
    def expires(self) -> float:
        return self.used + self.idle_s

    def renew(self, now: float | None = None) -> None:
        self.used = time.monotonic() if now is None else now


class RateWindow:
    """Accepted events in the last second, per key. An event counts while it is less than a second old on both
    clocks: sim time (so a controller answering every control tick is within its limits at any clock speed) and
    wall time (so a world slower than real time, or paused, does not pile up an agent's wall-paced commands)."""

    def __init__(self) -> None:
        self._q: dict[str, deque[tuple[float, float]]] = {}

    def count(self, key: str, sim_now: float, wall_now: float) -> int:
        q = self._q.get(key)
        if q is None:
            return 0
        if q and q[-1][0] > sim_now:  # sim time went back (reset): nothing counted is in this world's past
            q.clear()
        while q and (q[0][0] <= sim_now - 1.0 or q[0][1] <= wall_now - 1.0):
            q.popleft()
        if not q:
            del self._q[key]
            return 0
        return len(q)

    def add(self, key: str, sim_now: float, wall_now: float) -> None:
        self._q.setdefault(key, deque()).append((sim_now, wall_now))

    def forget(self, key: str) -> None:
        self._q.pop(key, None)


class Departed:
    """Clients known to be gone (their session closed): their late commands are dropped until they rejoin."""

    def __init__(self) -> None:
        self._at: dict[str, float] = {}

    def mark(self, client: str) -> None:
        self._at.pop(client, None)
        self._at[client] = time.monotonic()
        while len(self._at) > DEPARTED_MEMORY:
            del self._at[next(iter(self._at))]

    def clear(self, client: str) -> None:
        self._at.pop(client, None)

    def __contains__(self, client: object) -> bool:
        return client in self._at
