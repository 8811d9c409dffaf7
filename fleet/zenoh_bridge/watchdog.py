"""Hung agents: the SDK beats on `agent/<id>/heartbeat` a few times a second; an agent whose beat is late by
half a period more than one period (1.5 periods since the last, checked every quarter period) is reported as
`agent_unresponsive`, naming it and the robots it holds — within 2 heartbeats of its last sign of life. The
deadman stops its robots independently; its leases stay (it may wake up: `agent_responsive`) until they lapse
idle or its session closes.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import zenoh

from fleet.zenoh_api import Heartbeat, Keys, decode
from sim.errors import FleetError

log = logging.getLogger("fleetnav.zenoh")
LATE_FACTOR = 1.5  # periods of silence before an agent is reported
MIN_CHECK_S = 0.01


@dataclass
class Beat:
    period: float
    last: float  # time.monotonic() of the last beat received
    unresponsive: bool = False


class Watchdog:
    """Zenoh's thread records beats; a thread of its own notices silence. `on_change(agent, silent_s, period,
    responsive)` is called once when an agent goes silent and once when it beats again."""

    def __init__(self, keys: Keys, on_change: Callable[[str, float, float, bool], None],
                 check_s: float = 0.05) -> None:
        self.keys, self.on_change, self.check_s = keys, on_change, check_s
        self.beats: dict[str, Beat] = {}
        self.reported = 0
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="fleetnav-zenoh-watchdog", daemon=True)
        self._thread.start()

    def on_beat(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        try:
            hb = decode(Heartbeat, sample.payload.to_bytes(), key)
        except FleetError as exc:  # a malformed beat is logged, never fatal
            log.warning("malformed heartbeat on %s: %s", key, exc)
            return
        now = time.monotonic()
        with self._lock:
            beat = self.beats.get(hb.agent)
            woke = beat is not None and beat.unresponsive
            self.beats[hb.agent] = Beat(hb.period, now)
        if woke:
            self.on_change(hb.agent, 0.0, hb.period, True)

    def forget(self, agent: str) -> None:
        """The agent left (its liveliness token is gone): nothing more to watch."""
        with self._lock:
            self.beats.pop(agent, None)

    def _run(self) -> None:
        while not self._stop.wait(self._interval()):
            now = time.monotonic()
            late: list[tuple[str, float, float]] = []
            with self._lock:
                for agent, b in self.beats.items():
                    if not b.unresponsive and now - b.last > LATE_FACTOR * b.period:
                        b.unresponsive = True
                        late.append((agent, now - b.last, b.period))
            for agent, silent, period in late:
                self.reported += 1
                try:
                    self.on_change(agent, silent, period, False)
                except Exception:  # the watchdog must keep watching
                    log.exception("reporting unresponsive agent %s failed", agent)

    def _interval(self) -> float:
        with self._lock:
            shortest = min((b.period for b in self.beats.values()), default=4 * self.check_s)
        return max(MIN_CHECK_S, min(self.check_s, shortest / 4))

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2)
