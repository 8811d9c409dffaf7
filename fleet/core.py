"""ServiceCore: the state and machinery of FleetService (see fleet/service.py for the façade).

It owns the World. In service mode one sim thread runs it; callers submit commands through a thread-safe
queue and get futures back; reads come from an immutable snapshot published after each control tick. In
batch mode the same service is stepped synchronously, as fast as possible, with no threads.
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
from typing import TYPE_CHECKING, Any, Self, TypeVar, cast

import numpy as np

from fleet import validation
from fleet.battery import BatteryBank
from fleet.config import FleetConfig
from fleet.control import ControlLoop
from fleet.events import EventBus
from fleet.paths import Workspace, robot_model, world_file
from fleet.safety import SafetyEnvelope
from fleet.supervision import CMD_BUDGET_S, MAX_TICK_FAILURES, Health, dead, describe, internal, overrun
from fleet.types import FleetSnapshot
from sim import Clock, ClockMode, FleetError, Pose2D, RobotSpec, World
from sim.errors import ErrorCode
from sim.read_policy import policy as read_policy
from sim.types import Plane, WorldDescription
from sim.urdf_robot import LoadedRobot

if TYPE_CHECKING:
    from fleet.service import FleetService
    from planning import LayeredCostmap, OccupancyGrid

T = TypeVar("T")
CALL_TIMEOUT_S = 60.0


class ServiceCore:
    """The world, the sim thread and command queue, the snapshot; operation mixins build on this."""

    def __init__(self, config: FleetConfig | None = None) -> None:
        self.config = config or FleetConfig()
        self.workspace = Workspace(self.config.workspace)
        self.events = EventBus()
        self.clock = Clock(ClockMode.PAUSED)
        self._queue: queue.SimpleQueue[tuple[Callable[[], Any], Future[Any], float]] = queue.SimpleQueue()
        self.health = Health()
        self.read_only = False  # set by a read-only front door: FleetService refuses every mutating operation
        self._deadline, self._budget, self._overran = math.inf, math.inf, False
        self._thread: threading.Thread | None = None
        self._running = False
        self._draining = False
        self._wake = threading.Event()
        self.world: World
        self.docks: dict[str, Pose2D] = {}
        self._specs: dict[str, LoadedRobot] = {}
        # Hooks for front doors, run on the sim thread. Listeners get each published snapshot; a gate, when
        # set, is called before every control tick and may block (lock-step agents over Zenoh).
        self.tick_listeners: list[Callable[[FleetSnapshot], None]] = []
        # Called after every physics step (sim thread): a command accepted before the step took effect in it.
        self.step_listeners: list[Callable[[], None]] = []
        self.control_gate: Callable[[float], None] | None = None
        self._build(self.config.world)

    # ---- construction and reset -----------------------------------------------------------------------

    def _build(self, world_name: str) -> None:
        from fleet.registry import RobotRegistry
        from fleet.tasks import TaskManager
        from fleet.tasks.docks import dock_table

        c = self.config
        path = world_file(world_name)
        self.world = World.from_sdf(path, physics_hz=c.physics_hz, seed=c.seed, fidelity=c.fidelity)
        self.world_path = path
        desc = self.world.description
        self.bounds = _fence_bounds(desc)  # the geofence; validation allows poses within it + a margin
        self.safety = SafetyEnvelope(c.safety, self.bounds, control_hz=c.control_hz)
        self.battery = BatteryBank(c.battery)
        # Worlds mark docks as `dock_*` models (visual pads); the battery bank charges at all of them.
        self.docks = dock_table(desc)
        self.battery.docks = np.array([[p.x, p.y] for p in self.docks.values()], dtype=float).reshape(-1, 2)
        self.registry = RobotRegistry()
        self.control = ControlLoop(cast("FleetService", self))
        self.tasks = TaskManager(cast("FleetService", self))
        self.control.add_source(self.tasks)
        self._static_grid: OccupancyGrid | None = None
        self._costmaps: dict[str, LayeredCostmap] = {}
        self._keepouts: list[list[tuple[float, float]]] = []
        try:
            self._init_extensions()
        except BaseException:  # a bad config section: free the PyBullet client, then let the error out
            self.world.close()
            raise
        self._steps_per_control = max(1, round(c.physics_hz / c.control_hz))
        self._rtf_window: tuple[float, float] = (time.perf_counter(), self.world.time)
        self._rtf = float("nan")
        self._snapshots: dict[str, tuple[Any, np.ndarray]] = {}  # name → (world snapshot, battery)
        self._last_snapshot: str | None = None
        self._publish()

    def _init_extensions(self) -> None:
        """Hook for operation mixins to set up their state on each (re)build of the world."""

    def default_spec(self, model: str | None = None) -> RobotSpec:
        return self.robot_model(model).spec

    def robot_model(self, model: str | None = None) -> LoadedRobot:
        """A robot model (name, .yaml/.urdf/.xacro file or URDF text) and what its description left out."""
        key = model or self.config.robot_model
        if key not in self._specs:
            self._specs[key] = robot_model(key, package_path=self.config.package_path)
        return self._specs[key]

    # ---- threading: one sim thread, a command queue, futures -------------------------------------------

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

    # ---- stepping (both modes) -------------------------------------------------------------------------

    def advance(self, seconds: float) -> None:
        """Batch mode: step as fast as possible for `seconds` of sim time."""
        self.call(lambda: self._step(round(seconds * self.world.physics_hz)))

    def step(self, n: int = 1) -> float:
        validation.steps(n)

        def do() -> float:
            self._step(n)
            return self.world.time

        return self.call(do)

    def _step(self, n: int) -> None:
        """n physics steps; the control loop runs every `_steps_per_control` steps (sim time)."""
        w = self.world
        for _ in range(n):
            if self._deadline != math.inf:
                self.check_budget()
            tick = w.step_count % self._steps_per_control == 0
            # Callers wait at most one physics step, even when the sim lags: a manual command drained here reaches
            # the world's command at once (ControlLoop.apply_manual), so this very step integrates it. In
            # lock-step, commands apply only at control ticks so a run does not depend on when messages arrive.
            if self._thread is not None and not self._draining and (tick or self.control_gate is None):
                self._drain()
            if tick:
                if self.control_gate is not None:
                    self.control_gate(w.time)  # lock-step: wait for the agents' commands for this tick
                self.control.tick()  # behaviours → avoidance → safety envelope → world commands
            before = w.table.f["x"].copy(), w.table.f["y"].copy()
            w.step()
            self.control.after_step(before)  # battery, collisions, near misses
            for hook in self.step_listeners:
                hook()
            if w.step_count % self._steps_per_control == 0:
                self._publish()
                for listener in self.tick_listeners:
                    listener(self._snapshot)

    def _publish(self) -> None:
        w, reg = self.world, self.registry
        t = w.table
        now_wall = time.perf_counter()
        wall0, sim0 = self._rtf_window
        if now_wall - wall0 >= 0.5:
            self._rtf = (w.time - sim0) / (now_wall - wall0)
            self._rtf_window = (now_wall, w.time)
        names = tuple(t.names)
        self._snapshot = FleetSnapshot(
            time=w.time, step_count=w.step_count, world=w.name, clock_mode=self.clock.mode.value,
            real_time_factor=self._rtf, names=names,
            pose=_ro(np.column_stack([t.f["x"], t.f["y"], t.f["yaw"]])),
            twist=_ro(np.column_stack([t.f["v"], t.f["w"]])), cmd=_ro(np.column_stack([t.f["cmd_v"], t.f["cmd_w"]])),
            battery=_ro(self.battery.soc.copy()), in_collision=_ro(t.b["in_collision"].copy()),
            fidelity=tuple(w.fidelities[n] for n in names),
            controller=tuple(self.control.owner(n) for n in names),
            estopped=tuple(self.safety.is_estopped(n) for n in names),
            lease=tuple(self.safety.holder(n) for n in names),
            namespace=tuple(reg.get(n).namespace if reg.has(n) else n for n in names),
            fleet_estopped=self.safety.fleet_estop is not None,
            active_tasks=self.control.active_count(), last_event_seq=self.events.last_seq)

    def repace(self) -> None:
        """Time jumped (reset, restore, load): anchor the real-time pacing at the new time, so no catch-up."""
        self.clock.set_mode(self.clock.mode, self.world, self.clock.speed)
        self._rtf_window = (time.perf_counter(), self.world.time)

    @property
    def sim_time(self) -> float:
        """The world's time now (read after a command applied; the snapshot lags by up to one control tick)."""
        return float(self.world.time)

    @property
    def snapshot(self) -> FleetSnapshot:
        """The latest published state. Lock-free: a new object replaces the old one atomically."""
        return self._snapshot

    def reset(self) -> None:
        """Rebuild the world from its file: robots removed, time 0, RNG reseeded."""

        def do() -> None:
            self.control.cancel_all("world reset")
            self.world.close()
            self._build(str(self.world_path))
            self.repace()
            self.events.publish(0.0, "reset", message=f"world {self.world.name} reset")

        self.call(do)

    def load_world(self, name_or_path: str) -> None:
        path = self.workspace.world(name_or_path)

        def do() -> None:
            from sim import parse_sdf

            with read_policy(self.workspace.readable):
                parse_sdf(str(path))  # a broken file fails here, before the running world is closed
                self.control.cancel_all("world replaced")
                self.world.close()
                self._build(str(path))
            self.repace()
            self.events.publish(0.0, "world_loaded", message=f"loaded {path}")

        self.call(do)


def _fence_bounds(desc: WorldDescription) -> tuple[float, float, float, float]:
    """The geofence: the world's obstacles, grown to any finite ground plane (an open world's floor)."""
    xmin, ymin, xmax, ymax = desc.bounds()
    for m in desc.models:
        for _, c, wp in m.world_collisions():
            if isinstance(c.geometry, Plane):
                hx, hy = c.geometry.size[0] / 2, c.geometry.size[1] / 2
                xmin, ymin = min(xmin, wp.x - hx), min(ymin, wp.y - hy)
                xmax, ymax = max(xmax, wp.x + hx), max(ymax, wp.y + hy)
    return (xmin, ymin, xmax, ymax)


def _ro(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a
