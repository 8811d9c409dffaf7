"""One thread for what the world must not lose or block on: events, error reports, liveliness tokens.

The sim thread (and Zenoh's threads) only enqueue; this thread publishes with congestion control BLOCK, so a
slow subscriber slows the outbox, never the world, and nothing is silently dropped. The queue is unbounded
on purpose: events are rare next to sensor traffic.
"""

from __future__ import annotations

import logging
import queue
import threading
from collections.abc import Callable

import zenoh

log = logging.getLogger("fleetnav.zenoh")
JSON = zenoh.Encoding.APPLICATION_JSON


class Outbox:
    def __init__(self, session: zenoh.Session) -> None:
        self.session = session
        self._q: queue.SimpleQueue[Callable[[], None] | None] = queue.SimpleQueue()
        self._pubs: dict[str, zenoh.Publisher] = {}
        self._thread = threading.Thread(target=self._loop, name="fleetnav-zenoh-outbox", daemon=True)
        self._thread.start()

    def put(self, key: str, payload: bytes) -> None:
        self._q.put(lambda: self._publisher(key).put(payload))

    def do(self, fn: Callable[[], None]) -> None:
        """Run `fn` on the outbox thread, in order with the puts."""
        self._q.put(fn)

    def flush(self, timeout: float = 5.0) -> bool:
        done = threading.Event()
        self._q.put(done.set)
        return done.wait(timeout)

    def close(self) -> None:
        self._q.put(None)
        self._thread.join(timeout=10)
        for p in self._pubs.values():
            p.undeclare()
        self._pubs.clear()

    def _publisher(self, key: str) -> zenoh.Publisher:
        pub = self._pubs.get(key)
        if pub is None:
            pub = self._pubs[key] = self.session.declare_publisher(
                key, encoding=JSON, congestion_control=zenoh.CongestionControl.BLOCK, priority=zenoh.Priority.DATA)
        return pub

    def _loop(self) -> None:
        while (job := self._q.get()) is not None:
            try:
                job()
            except zenoh.ZError as exc:  # e.g. the session closed under us: the job is lost, say so
                log.warning("zenoh outbox: %s", exc)
