"""ServiceCore: the state and machinery of FleetService (see fleet/service.py for the façade).

It owns the World. In service mode one sim thread runs it; callers submit commands through a thread-safe
queue and get futures back; reads come from an immutable snapshot published after each control tick. In
batch mode the same service is stepped synchronously, as fast as possible, with no threads.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from fleet import validation
from fleet.battery import BatteryBank
from fleet.command_queue import CALL_TIMEOUT_S, CommandQueue
from fleet.config import FleetConfig
from fleet.control import ControlLoop
from fleet.events import EventBus
from fleet.paths import Workspace, robot_model, world_file
from fleet.safety import SafetyEnvelope
from fleet.service_view import ServiceView
from fleet.types import FleetSnapshot
from sim import Clock, ClockMode, Pose2D, RobotSpec, World
from sim.read_policy import policy as read_policy
from sim.types import Plane, WorldDescription
from sim.urdf_robot import LoadedRobot

if TYPE_CHECKING:
    from fleet.service import FleetService
    from planning import LayeredCostmap, OccupancyGrid

__all__ = ["CALL_TIMEOUT_S", "ServiceCore"]


class ServiceCore(CommandQueue):
    """The world, the snapshot, stepping and reset; the sim thread and command queue are CommandQueue's;
    operation mixins build on this."""

    def __init__(self, config: FleetConfig | None = None) -> None:
        self.config = config or FleetConfig()
        self.workspace = Workspace(self.config.workspace)
        self.events = EventBus()
        self.clock = Clock(ClockMode.PAUSED)
        self._init_queue()
        self.read_only = False  # set by a read-only front door: FleetService refuses every mutating operation
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
        self.view = ServiceView(cast("FleetService", self))  # what tasks, avoidance, swarm, deadlocks see
        self.tasks = TaskManager(self.view)
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
