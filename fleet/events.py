"""The in-process event bus: the sim thread publishes, recorders and front doors subscribe or poll."""

from __future__ import annotations

import itertools
import threading
from collections import deque
from collections.abc import Callable, Iterable
from typing import Any

from fleet.types import Event

Listener = Callable[[Event], None]


class EventBus:
    """Thread-safe publish/subscribe plus a bounded history for pollers (`since(seq)`).

    Subscribers run on the publishing thread (the sim thread), so they must be quick: front doors hand
    events to their own queues."""

    def __init__(self, history: int = 10_000) -> None:
        self._lock = threading.Lock()
        self._seq = itertools.count(1)
        self._history: deque[Event] = deque(maxlen=history)
        self._listeners: list[tuple[frozenset[str] | None, Listener]] = []
        self.last_seq = 0

    def publish(self, stamp: float, kind: str, robots: Iterable[str] = (), message: str = "",
                **data: Any) -> Event:
        with self._lock:
            ev = Event(next(self._seq), stamp, kind, tuple(robots), message, data)
            self._history.append(ev)
            self.last_seq = ev.seq
            listeners = list(self._listeners)
        for kinds, cb in listeners:
            if kinds is None or kind in kinds:
                cb(ev)
        return ev

    def subscribe(self, callback: Listener, kinds: Iterable[str] | None = None) -> Callable[[], None]:
        entry = (None if kinds is None else frozenset(kinds), callback)
        with self._lock:
            self._listeners.append(entry)

        def unsubscribe() -> None:
            with self._lock:
                if entry in self._listeners:
                    self._listeners.remove(entry)

        return unsubscribe

    def since(self, seq: int = 0, kinds: Iterable[str] | None = None, limit: int = 1000) -> list[Event]:
        wanted = None if kinds is None else set(kinds)
        with self._lock:
            evs = [e for e in self._history if e.seq > seq and (wanted is None or e.kind in wanted)]
        return evs[-limit:]

    def clear(self) -> None:
        with self._lock:
            self._history.clear()
