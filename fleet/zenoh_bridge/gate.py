"""The bridge's control gate: hands work to the sim thread, stamps command latency, and runs lock-step.

Installed as `service.control_gate`, so it runs on the sim thread right before every control tick. In lock-step
it publishes the tick on `fleet/clock` and waits until every registered agent has answered that tick with a
command for each of its robots (or until `timeout_s` of wall time: the agent is declared hung, its robots stop).
While it waits, the bridge's own work (agents' commands and queries) runs here, on the sim thread, so an agent
can still query the world mid-tick. Calls that rebuild the world (reset) are never run inside the gate: they
wait for the sim loop, because the tick in progress belongs to the world that is about to be replaced.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable
from concurrent.futures import Future
from typing import TYPE_CHECKING, Any, TypeVar

if TYPE_CHECKING:
    from fleet.service import FleetService

T = TypeVar("T")
log = logging.getLogger("fleetnav.zenoh")
LATENCY_WINDOW = 100_000  # most recent command latencies kept for stats


class Gate:
    def __init__(self, service: FleetService, *, lockstep: bool, timeout_s: float,
                 on_tick: Callable[[int, float], None], on_hung: Callable[[str, list[str]], None]) -> None:
        self.service = service
        self.lockstep = lockstep
        self.timeout_s = timeout_s
        self.on_tick, self.on_hung = on_tick, on_hung
        self._cond = threading.Condition()
        self._waiting = False
        self._work: list[tuple[Callable[[], Any], Future[Any]]] = []
        self.agents: dict[str, set[str]] = {}  # lock-step agent → its robots
        self._answered: dict[tuple[str, str], int] = {}  # (agent, robot) → last tick answered
        self._sent: list[tuple[float, float]] = []  # (sent, accepted) wall times of commands not yet stepped
        self.latencies: deque[float] = deque(maxlen=LATENCY_WINDOW)  # command sent → applied by a physics step, s
        self.accept_latencies: deque[float] = deque(maxlen=LATENCY_WINDOW)  # sent → through the envelope, s
        # Per stage (issue 17), s: sent → received by the bridge, received → envelope, envelope → applied.
        self.receive_latencies: deque[float] = deque(maxlen=LATENCY_WINDOW)
        self.envelope_latencies: deque[float] = deque(maxlen=LATENCY_WINDOW)
        self.apply_latencies: deque[float] = deque(maxlen=LATENCY_WINDOW)
        self.ticks = 0
        phys, ctrl = service.config.physics_hz, service.config.control_hz
        self._steps_per_tick = max(1, round(phys / ctrl))  # as ServiceCore counts control ticks

    # ---- work for the sim thread -------------------------------------------------------------------------

    def run(self, fn: Callable[[], T], *, in_gate: bool = True) -> Future[T]:
        """Run `fn` on the sim thread: inside the gate if the world is waiting there (and `in_gate`), else
        through the service's queue. Never blocks."""
        with self._cond:
            if self._waiting and in_gate:
                fut: Future[T] = Future()
                self._work.append((fn, fut))
                self._cond.notify()
                return fut
        return self.service.submit(fn)

    def _run_work(self) -> None:
        with self._cond:
            work, self._work = self._work, []
        for fn, fut in work:
            if fut.set_running_or_notify_cancel():
                try:
                    fut.set_result(fn())
                except BaseException as exc:  # delivered to whoever waits on the future
                    fut.set_exception(exc)

    # ---- lock-step registry (sim thread) ------------------------------------------------------------------

    def register(self, agent: str, robots: list[str]) -> None:
        if robots:
            self.agents[agent] = set(robots)
        else:
            self.unregister(agent)

    def unregister(self, agent: str) -> None:
        self.agents.pop(agent, None)
        for key in [k for k in self._answered if k[0] == agent]:
            del self._answered[key]

    def answered(self, agent: str, robot: str, tick: int) -> None:
        key = (agent, robot)
        self._answered[key] = max(tick, self._answered.get(key, -1))

    def applied(self, sent: float, received: float | None = None) -> None:
        """A command sent at wall time `sent` (received by the bridge at `received`) passed the envelope just
        now; it is in the world's command already, and the next physics step applies it (`stepped`)."""
        now = time.time()
        self.accept_latencies.append(now - sent)
        if received is not None:
            self.receive_latencies.append(received - sent)
            self.envelope_latencies.append(now - received)
        self._sent.append((sent, now))

    def stepped(self) -> None:
        """After each physics step (ServiceCore.step_listeners): the commands accepted before it are applied."""
        if self._sent:
            wall = time.time()
            self.latencies.extend(wall - s for s, _ in self._sent)
            self.apply_latencies.extend(wall - a for _, a in self._sent)
            self._sent.clear()

    def forget_ticks(self) -> None:
        """The world was rebuilt: tick numbers start again from 0."""
        self._answered.clear()

    def tick_of(self, step_count: int) -> int:
        return step_count // self._steps_per_tick

    # ---- the gate ---------------------------------------------------------------------------------------

    def __call__(self, now: float) -> None:
        self.ticks += 1
        self._run_work()
        if self.lockstep and self.agents:
            self._wait_for_agents(self.tick_of(self.service.world.step_count), now)
        if self.service.step_listeners.count(self.stepped) == 0:
            self.stepped()  # not hooked to physics steps: count the control tick that follows as the applier

    def _missing(self, tick: int) -> list[str]:
        names = set(self.service.world.table.names)
        return [a for a, robots in self.agents.items()
                if any(self._answered.get((a, r), -1) < tick for r in robots & names)]

    def _wait_for_agents(self, tick: int, now: float) -> None:
        with self._cond:
            self._waiting = True  # before the tick goes out: an answer may come back at once
        deadline = time.monotonic() + self.timeout_s
        try:
            self.on_tick(tick, now)
            while True:
                self._run_work()
                missing = self._missing(tick)
                remaining = deadline - time.monotonic()
                if not missing or remaining <= 0:
                    break
                with self._cond:
                    if not self._work:
                        self._cond.wait(min(remaining, 0.05))
        finally:
            with self._cond:
                self._waiting = False
            self._run_work()  # anything handed in while we were leaving
        for agent in self._missing(tick):
            robots = sorted(self.agents.get(agent, ()))
            log.warning("lock-step agent %s did not answer tick %d within %.3g s: declared hung", agent, tick,
                        self.timeout_s)
            self.unregister(agent)
            self.on_hung(agent, robots)

    def latency_stats(self) -> dict[str, Any]:
        """Command latency percentiles, ms: from the send to the envelope (`accepted`) and to the physics step
        that applies it (`applied`); per stage: send → bridge (`receive`), bridge → envelope (`envelope`),
        envelope → applied (`apply`)."""
        return {"applied": percentiles(self.latencies), "accepted": percentiles(self.accept_latencies),
                "receive": percentiles(self.receive_latencies), "envelope": percentiles(self.envelope_latencies),
                "apply": percentiles(self.apply_latencies)}


def percentiles(samples: Iterable[float]) -> dict[str, Any]:
    lat = sorted(samples)
    if not lat:
        return {"count": 0, "p50_ms": None, "p99_ms": None, "max_ms": None}

    def q(p: float) -> float:
        return round(1e3 * lat[min(len(lat) - 1, math.ceil(p * len(lat)) - 1)], 3)

    return {"count": len(lat), "p50_ms": q(0.5), "p99_ms": q(0.99), "max_ms": round(1e3 * lat[-1], 3)}
