"""CommandQueue: the sim thread of FleetService and the queue of commands it drains (service mode).

Callers submit commands through a thread-safe queue and get futures back; the sim thread drains the queue
between steps and runs each command under its own wall budget (fleet/supervision.py): a failing command fails
alone, the world keeps stepping, and once the thread is dead every queued and later call fails fast with
SIM_DEAD. In batch mode (no thread) or on the sim thread itself a command runs at once. ServiceCore
(fleet/core.py) owns the world and the stepping this drives.
"""

from __future__ import annotations

import asyncio
import math
import queue
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future
from concurrent.futures import TimeoutError as FutureTimeout
from typing import TYPE_CHECKING, Any, Self, TypeVar

from fleet.supervision import CMD_BUDGET_S, MAX_TICK_FAILURES, Health, dead, describe, internal, overrun
from sim import Clock, ClockMode, FleetError, World
from sim.errors import ErrorCode

if TYPE_CHECKING:
    from fleet.events import EventBus

T = TypeVar("T")
CALL_TIMEOUT_S = 60.0


class CommandQueue:
    """Mixed into ServiceCore, which provides the world, its clock, events and `_step`."""

    world: World
    clock: Clock
    events: EventBus
    _steps_per_control: int

    if TYPE_CHECKING:
        def _step(self, n: int) -> None: ...

    def _init_queue(self) -> None:
        self._queue: queue.SimpleQueue[tuple[Callable[[], Any], Future[Any], float]] = queue.SimpleQueue()
        self.health = Health()
        self._deadline, self._budget, self._overran = math.inf, math.inf, False
        self._thread: threading.Thread | None = None
        self._running = False
        self._draining = False
        self._wake = threading.Event()

    @property
    def threaded(self) -> bool:
        return self._thread is not None

    def start(self, mode: ClockMode | str = ClockMode.REALTIME, speed: float = 1.0) -> Self:
        """Service mode: run the world in its own thread, paced by the clock."""
        if self._thread is not None and self.health.dead_reason is None:
            return self
        self.health.alive, self.health.dead_reason = True, None
        self.clock.set_mode(mode, self.world, speed)
        self._running = True
        self._thread = threading.Thread(target=self._sim_loop, name="fleetnav-sim", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._running = False
        self._wake.set()
        if self._thread is not None:
            self._thread.join(timeout=10)
        self._thread = None

    def close(self) -> None:
        self.stop()
        self.world.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def submit(self, fn: Callable[[], T], budget: float = CMD_BUDGET_S) -> Future[T]:
        """Run `fn` on the sim thread between steps; in batch mode (or on the sim thread) run it now. In service
        mode a command that steps the world longer than `budget` wall seconds stops with TIMEOUT."""
        fut: Future[T] = Future()
        if self.health.dead_reason is not None:
            fut.set_exception(dead(self.health.dead_reason))
            return fut
        if self._thread is None or threading.current_thread() is self._thread:
            self._run_command(fn, fut, math.inf)
            return fut
        self._queue.put((fn, fut, budget))
        self._wake.set()
        if self.health.dead_reason is not None:  # it died while we queued: nobody will run it
            self._fail_pending()
        return fut

    def call(self, fn: Callable[[], T], timeout: float = CALL_TIMEOUT_S) -> T:
        try:
            return self.submit(fn).result(timeout=timeout)
        except FutureTimeout:
            raise self._busy_error(timeout) from None

    async def acall(self, fn: Callable[[], T], timeout: float = CALL_TIMEOUT_S) -> T:
        try:
            return await asyncio.wait_for(asyncio.wrap_future(self.submit(fn)), timeout)
        except TimeoutError:
            raise self._busy_error(timeout) from None

    def _busy_error(self, timeout: float) -> FleetError:
        h = self.health
        if h.dead_reason is not None:
            return dead(h.dead_reason)
        return FleetError(ErrorCode.TIMEOUT, f"no answer from the sim thread within {timeout:g} s (it runs "
                          f"{h.command or 'the world'})", "call sim_health; the command may still complete")

    def _run_command(self, fn: Callable[[], T], fut: Future[T], budget: float) -> None:
        """One command: its own wall budget, its failure delivered through the future, the world untouched."""
        if not fut.set_running_or_notify_cancel():
            return
        h = self.health
        saved = (self._deadline, self._budget, h.command, h.command_started)
        now = time.perf_counter()
        if now + budget < self._deadline:  # a nested call keeps the outer command's (tighter) deadline
            self._deadline, self._budget = now + budget, budget
        h.command, h.command_started = describe(fn), now
        try:
            fut.set_result(fn())
        except FleetError as exc:
            if exc.code is ErrorCode.TIMEOUT and self._overran:
                h.overruns += 1
                h.note(f"{h.command}: {exc.message}")
            fut.set_exception(exc)
        except Exception as exc:  # a bug in the command: the caller gets INTERNAL, the world goes on
            h.command_errors += 1
            err = internal(exc)
            h.note(f"{h.command}: {err.message}")
            fut.set_exception(err)
        except BaseException as exc:  # the thread itself is going down: the caller must not wait
            fut.set_exception(dead(f"{type(exc).__name__} in {h.command}"))
            raise
        finally:
            self._overran = False
            self._deadline, self._budget, h.command, h.command_started = saved

    def _drain(self) -> None:
        """Run queued commands on the sim thread (not re-entrant: a command that steps the world does not
        drain the queue again from inside its own steps)."""
        self._draining = True
        try:
            while True:
                try:
                    fn, fut, budget = self._queue.get_nowait()
                except queue.Empty:
                    return
                self._run_command(fn, fut, budget)
        finally:
            self._draining = False

    def _sim_loop(self) -> None:
        failures = 0
        try:
            while self._running:
                try:
                    self._loop_once()
                    failures = 0
                except FleetError as exc:  # physics blew up: the world halts and says why; callers see it
                    self.events.publish(self.world.time, "physics_unstable", message=exc.message)
                    self.clock.set_mode(ClockMode.PAUSED, self.world)
                except Exception as exc:  # a tick failed (not a command): report it, keep the world going
                    failures += 1
                    self.health.tick_errors += 1
                    self.health.note(f"tick: {internal(exc).message}")
                    self.events.publish(self.world.time, "sim_error", message=internal(exc).message)
                    if failures >= MAX_TICK_FAILURES:
                        raise
        except BaseException as exc:
            self._die(f"{failures} ticks failed in a row; last: {type(exc).__name__}: {str(exc)[:200]}"
                      if failures else f"{type(exc).__name__}: {str(exc)[:200]}")

    def _loop_once(self) -> None:
        self._drain()
        steps = self.clock.steps_due(self.world, max_steps=self._steps_per_control)
        if steps == 0:
            wait = None if self.clock.mode is ClockMode.PAUSED else self.clock.seconds_until_next_step(self.world)
            self._wake.wait(timeout=min(wait, 0.5) if wait is not None and wait >= 0 else 0.5)
            self._wake.clear()
            return
        self._step(steps)

    def _die(self, reason: str) -> None:
        self.health.alive, self.health.dead_reason = False, reason
        self.health.died_at_wall = time.time()
        self.health.note(f"sim thread died: {reason}")
        self._running = False
        self._fail_pending()

    def _fail_pending(self) -> None:
        while True:
            try:
                _, fut, _ = self._queue.get_nowait()
            except queue.Empty:
                return
            if fut.set_running_or_notify_cancel():
                fut.set_exception(dead(self.health.dead_reason))

    def check_budget(self) -> None:
        """Called at every step a command takes: stop it once it has overrun its wall budget."""
        if time.perf_counter() > self._deadline:
            self._overran = True
            raise overrun(self._budget, self.world.time)
