"""ServiceCore: the state and machinery of FleetService (see fleet/service.py for the façade).

It owns the World. In service mode one sim thread runs it; callers submit commands through a thread-safe
queue and get futures back; reads come from an immutable snapshot published after each control tick. In
batch mode the same service is stepped synchronously, as fast as possible, with no threads.
"""

from __future__ import annotations

import asyncio
import queue
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future
from typing import TYPE_CHECKING, Any, Self, TypeVar, cast

import numpy as np

from fleet.battery import BatteryBank
from fleet.config import FleetConfig
from fleet.control import ControlLoop
from fleet.events import EventBus
from fleet.paths import Workspace, robot_file, world_file
from fleet.safety import SafetyEnvelope
from fleet.types import FleetSnapshot
from sim import Clock, ClockMode, FleetError, Pose2D, RobotSpec, World, load_robot_spec
from sim.errors import ErrorCode
from sim.types import Plane, WorldDescription

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
        self._queue: queue.SimpleQueue[tuple[Callable[[], Any], Future[Any]]] = queue.SimpleQueue()
        self._thread: threading.Thread | None = None
        self._running = False
        self._draining = False
        self._wake = threading.Event()
        self.world: World
        self.docks: dict[str, Pose2D] = {}
        self._specs: dict[str, RobotSpec] = {}
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
        self.safety = SafetyEnvelope(c.safety, _fence_bounds(desc))
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
        self._publish()

    def _init_extensions(self) -> None:
        """Hook for operation mixins to set up their state on each (re)build of the world."""

    def default_spec(self, model: str | None = None) -> RobotSpec:
        key = model or self.config.robot_model
        if key not in self._specs:
            self._specs[key] = load_robot_spec(robot_file(key))
        return self._specs[key]

    # ---- threading: one sim thread, a command queue, futures -------------------------------------------

    @property
    def threaded(self) -> bool:
        return self._thread is not None

    def start(self, mode: ClockMode | str = ClockMode.REALTIME, speed: float = 1.0) -> Self:
        """Service mode: run the world in its own thread, paced by the clock."""
        if self._thread is not None:
            return self
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

    def submit(self, fn: Callable[[], T]) -> Future[T]:
        """Run `fn` on the sim thread between steps; in batch mode (or on the sim thread) run it now."""
        fut: Future[T] = Future()
        if self._thread is None or threading.current_thread() is self._thread:
            try:
                fut.set_result(fn())
            except BaseException as exc:  # delivered to the caller through the future, never swallowed
                fut.set_exception(exc)
            return fut
        self._queue.put((fn, fut))
        self._wake.set()
        return fut

    def call(self, fn: Callable[[], T], timeout: float = CALL_TIMEOUT_S) -> T:
        return self.submit(fn).result(timeout=timeout)

    async def acall(self, fn: Callable[[], T]) -> T:
        return await asyncio.wrap_future(self.submit(fn))

    def _drain(self) -> None:
        """Run queued commands on the sim thread (not re-entrant: a command that steps the world does not
        drain the queue again from inside its own steps)."""
        self._draining = True
        try:
            while True:
                try:
                    fn, fut = self._queue.get_nowait()
                except queue.Empty:
                    return
                if fut.set_running_or_notify_cancel():
                    try:
                        fut.set_result(fn())
                    except BaseException as exc:  # the caller gets it from the future
                        fut.set_exception(exc)
        finally:
            self._draining = False

    def _sim_loop(self) -> None:
        while self._running:
            self._drain()
            steps = self.clock.steps_due(self.world, max_steps=self._steps_per_control)
            if steps == 0:
                wait = None if self.clock.mode is ClockMode.PAUSED else self.clock.seconds_until_next_step(self.world)
                self._wake.wait(timeout=wait if wait is not None else 0.5)
                self._wake.clear()
                continue
            try:
                self._step(steps)
            except FleetError as exc:  # physics blew up: the world halts and says why; callers see it
                self.events.publish(self.world.time, "physics_unstable", message=exc.message)
                self.clock.set_mode(ClockMode.PAUSED, self.world)

    # ---- stepping (both modes) -------------------------------------------------------------------------

    def advance(self, seconds: float) -> None:
        """Batch mode: step as fast as possible for `seconds` of sim time."""
        self.call(lambda: self._step(round(seconds * self.world.physics_hz)))

    def step(self, n: int = 1) -> float:
        if n < 0 or n > 10_000_000:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"steps must be in [0, 1e7], got {n}")
        def do() -> float:
            self._step(n)
            return self.world.time

        return self.call(do)

    def _step(self, n: int) -> None:
        """n physics steps; the control loop runs every `_steps_per_control` steps (sim time)."""
        w = self.world
        for _ in range(n):
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
            self.events.publish(0.0, "reset", message=f"world {self.world.name} reset")

        self.call(do)

    def load_world(self, name_or_path: str) -> None:
        def do() -> None:
            path = world_file(name_or_path) if not name_or_path.endswith((".world", ".sdf")) else \
                self.workspace.resolve(name_or_path)
            self.control.cancel_all("world replaced")
            self.world.close()
            self._build(str(path))
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
