"""Query replies: each query is answered exactly once (its result, its error, or TIMEOUT once its budget is
spent) and then finalized at once, and no query worker waits on the sim thread.

Why finalize explicitly: Zenoh ends a query (the caller's `get` returns) when the Query object is dropped. An
error raised on the sim thread travels back in a Future whose traceback holds the frame that held the future,
a reference cycle that also holds the worker frame with the query in it; the query then lived until the cyclic
garbage collector ran, and callers saw no answer within their 10 s although the error reply had been sent.
"""

from __future__ import annotations

import heapq
import itertools
import logging
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass
from typing import Any

import zenoh

from fleet.zenoh_api import encode_error
from sim.errors import ErrorCode, FleetError

log = logging.getLogger("fleetnav.zenoh")
JSON = zenoh.Encoding.APPLICATION_JSON


@dataclass
class Later:
    """An answer the sim thread has yet to compute: its future and how to encode the result (on a worker)."""

    future: Future[Any]
    encode: Callable[[Any], bytes]


class Reply:
    """One query's single answer. Thread-safe: the worker, the sim thread's completion and the deadline race."""

    def __init__(self, query: zenoh.Query, key: str, now: Callable[[], float]) -> None:
        self.query: zenoh.Query | None = query
        self.key, self._now = key, now
        self.future: Future[Any] | None = None  # the sim work, while it may still be cancelled
        self._lock = threading.Lock()
        self.done = False

    def _claim(self) -> zenoh.Query | None:
        with self._lock:
            query, self.query, self.future, self.done = self.query, None, None, True
            return query  # None: answered already; the result is not kept until the deadline passes

    def ok(self, payload: bytes) -> None:
        if (query := self._claim()) is not None:
            _send(query, self.key, lambda: query.reply(self.key, payload, encoding=JSON))

    def error(self, exc: FleetError) -> bool:
        if (query := self._claim()) is None:
            return False
        _send(query, self.key, lambda: query.reply_err(encode_error(exc, self._now(), key=self.key), encoding=JSON))
        return True


def _send(query: zenoh.Query, key: str, send: Callable[[], None]) -> None:
    try:
        send()
    except Exception:  # e.g. the session closed: nothing to tell the caller, say it here
        log.exception("reply to query %s failed", key)
    finally:
        query.drop()


def overdue(budget: float, cancelled: bool, running: str | None) -> FleetError:
    """The TIMEOUT a query gets when the world has not answered within its budget."""
    what = ("it was dropped before it ran" if cancelled else
            f"it may still complete (the sim thread runs {running or 'the world'})")
    return FleetError(ErrorCode.TIMEOUT, f"no answer from the world within {budget:g} s; {what}",
                      "ask again, or read fleet/state for the outcome; the budget is query_budget_s")


class Deadlines:
    """Runs callbacks at monotonic deadlines on one thread (a timer thread per query would not scale)."""

    def __init__(self) -> None:
        self._heap: list[tuple[float, int, Callable[[], None]]] = []
        self._seq = itertools.count()
        self._cond = threading.Condition()
        self._closed = False
        self._thread = threading.Thread(target=self._run, name="fleetnav-zenoh-deadlines", daemon=True)
        self._thread.start()

    def at(self, when: float, fn: Callable[[], None]) -> None:
        with self._cond:
            heapq.heappush(self._heap, (when, next(self._seq), fn))
            self._cond.notify()

    def close(self) -> None:
        with self._cond:
            self._closed = True
            self._cond.notify()
        self._thread.join(timeout=5)

    def _run(self) -> None:
        while True:
            with self._cond:
                while not self._closed:
                    wait = self._heap[0][0] - time.monotonic() if self._heap else None
                    if wait is not None and wait <= 0:
                        break
                    self._cond.wait(timeout=wait)
                if self._closed:
                    return
                _, _, fn = heapq.heappop(self._heap)
            try:
                fn()
            except Exception:  # a failed reply must not stop the deadlines of every other query
                log.exception("query deadline callback failed")
