"""FleetService operations for formations, fleet commands, swarm behaviours, avoidance and deadlocks."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from pydantic import ValidationError

from fleet import sync  # noqa: F401  (registers the `sync` barrier task)
from fleet.avoidance import Avoidance, StaticClearance, make_avoidance
from fleet.core import ServiceCore
from fleet.deadlock import DeadlockConfig, DeadlockMonitor
from fleet.formations import (
    FORMATIONS,
    Formation,
    assign_slots,
    check_kind,
    check_slots,
    formation_offsets,
    heading_mean,
    random_slots,
    to_frame,
    to_world,
)
from fleet.swarm import BehaviourManager, behaviour_names
from fleet.sync import Barrier
from fleet.validation import summarize
from planning import LayeredCostmap
from sim.errors import ErrorCode, FleetError
from sim.types import Pose2D

if TYPE_CHECKING:
    from fleet.service import FleetService

COMMANDS = ("move", "stop", "formation", "sync", "return_home")
SEPARATION_MARGIN = 0.1  # m between footprints of robots placed in a formation


class FleetOps(ServiceCore):
    """Mixed into FleetService."""

    def _init_fleet_ops(self) -> None:
        """Called from FleetService._build after the control loop exists (register behaviours, avoidance)."""
        self.behaviours = BehaviourManager(self.view)
        self.control.add_source(self.behaviours)  # after the task manager: a task wins over a behaviour
        deadlock = self.config.deadlock
        self.deadlocks = DeadlockMonitor(self.view, _validated(DeadlockConfig, dict(deadlock), "deadlock"))
        self.control.sources.insert(0, self.deadlocks)  # a back-off overrides the task it interrupts
        self.avoidance: Avoidance = make_avoidance(self.config.avoidance)
        self.control.avoidance = self.avoidance
        self.formations: list[Formation] = []
        self.barriers: dict[str, Barrier] = {}
        self._clearance: StaticClearance | None = None
        self._placement: dict[tuple[float, Any], LayeredCostmap] = {}

    # ---- shared geometry --------------------------------------------------------------------------------

    def static_clearance(self) -> StaticClearance:
        """Distance to (and direction of) the nearest static obstacle, for avoidance, behaviours, back-offs."""
        grid = cast("FleetService", self).static_grid()
        if self._clearance is None or self._clearance.grid is not grid:
            self._clearance = StaticClearance(grid)
        return self._clearance

    def _free_fn(self, radius: float) -> Any:
        """Where a robot of `radius` may stand: the static map inflated by it, keep-out zones included."""
        key = (radius, tuple(tuple(map(tuple, p)) for p in self._keepouts))  # a new zone means a new costmap
        if key not in self._placement:
            cm = LayeredCostmap(cast("FleetService", self).static_grid(), robot_radius=radius)
            for poly in self._keepouts:
                cm.add_keepout(poly)
            self._placement.clear()
            self._placement[key] = cm
        return self._placement[key].is_free_many

    # ---- spawning in formation --------------------------------------------------------------------------

    def spawn_fleet(self, count: int, formation: str = "grid", centre: Pose2D | None = None, spacing: float = 1.5,
                    prefix: str = "robot", *, radius: float | None = None, model: str | None = None,
                    fidelity: str | None = None) -> dict[str, Any]:
        """Spawn `count` robots in a formation (line, column, grid, circle, wedge, random) about `centre`, every
        slot checked free of obstacles and robots. `random`: rejection sampling within `radius` of `centre`
        (default: the whole world) with a minimum separation of `spacing`."""
        check_kind(formation)
        if not (isinstance(count, int) and 1 <= count <= 1000):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"count must be an integer in [1, 1000], got {count!r}")
        if radius is not None and not (math.isfinite(radius) and radius > 0):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"radius must be > 0 m, got {radius}")
        spec = self.default_spec(model)
        min_sep = 2 * spec.footprint_radius + SEPARATION_MARGIN
        if not (math.isfinite(spacing) and spacing >= min_sep):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"spacing {spacing} m is below the minimum separation "
                             f"{min_sep:.2f} m (two footprint radii + {SEPARATION_MARGIN} m)",
                             f"use spacing ≥ {min_sep:.2f}")
        svc = cast("FleetService", self)

        def do() -> dict[str, Any]:
            xmin, ymin, xmax, ymax = self.world.description.bounds()
            c = centre or Pose2D((xmin + xmax) / 2, (ymin + ymax) / 2, 0.0)
            t = self.world.table
            existing = {n: (float(t.f["x"][i]), float(t.f["y"][i])) for i, n in enumerate(t.names)}
            free = self._free_fn(spec.footprint_radius)
            if formation == "random":
                r = radius if radius is not None else (math.hypot(xmax - xmin, ymax - ymin) / 2 if centre is None
                                                       else spacing * math.sqrt(count) + spacing)
                m = spec.footprint_radius  # inside the world's bounds (outside its walls may rasterise as free)
                xy = random_slots(count, c, r, spacing, free, self.world.rng,
                                  np.array(list(existing.values())).reshape(-1, 2),
                                  bounds=(xmin + m, ymin + m, xmax - m, ymax - m))
                offsets = to_frame(xy, c)
            else:
                offsets = formation_offsets(formation, count, spacing)
                xy = to_world(offsets, c)
            check_slots(xy, free, min_sep, existing)
            names = self._new_names(prefix, count)
            for name, (x, y) in zip(names, xy, strict=True):
                svc.spawn_robot(name, Pose2D(float(x), float(y), c.yaw), model=model, fidelity=fidelity)
            self._remember(Formation(formation, spacing, c.yaw, tuple(names), offsets))
            self.events.publish(self.world.time, "fleet_spawned", names, f"{count} robots in a {formation} "
                                f"formation at ({c.x:.2f}, {c.y:.2f})", formation=formation, spacing=spacing)
            return {"robots": names, "formation": formation, "spacing": spacing,
                    "centre": {"x": c.x, "y": c.y, "yaw": c.yaw},
                    "poses": {n: {"x": round(float(x), 4), "y": round(float(y), 4), "yaw": c.yaw}
                              for n, (x, y) in zip(names, xy, strict=True)}}

        return self.call(do)

    def _new_names(self, prefix: str, count: int) -> list[str]:
        if not prefix or not prefix.replace("_", "").replace("-", "").isalnum():
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"prefix must be letters, digits, '_' or '-', got {prefix!r}")
        taken, k = set(self.world.robot_names()), 1
        names: list[str] = []
        while len(names) < count:
            if f"{prefix}{k}" not in taken:
                names.append(f"{prefix}{k}")
            k += 1
        return names

    def _remember(self, f: Formation) -> None:
        self.formations.append(f)
        del self.formations[:-50]

    # ---- fleet commands ---------------------------------------------------------------------------------

    def fleet_command(self, command: str, robots: list[str] | None = None, *, target: Pose2D | None = None,
                      formation: str | None = None, spacing: float | None = None, queue: bool = False,
                      priority: int = 0, timeout_s: float | None = None, client: str = "default") -> dict[str, Any]:
        """A command to all robots (robots=None) or a subset:
        move (to `target`, formation kept: each robot goes to its slot about the target), stop, formation
        (change to `formation`/`spacing` about `target` or where the group is), sync (a barrier: each robot
        finishes its queued work, then all wait for the slowest), return_home (to the spawn poses).
        move/formation/return_home replace the robots' current work unless `queue` is true."""
        if command not in COMMANDS:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"unknown fleet command '{command}'",
                             f"commands: {', '.join(COMMANDS)}")
        if command == "move" and target is None:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, "move needs a target pose {x, y, yaw}")
        if formation is not None:
            check_kind(formation, FORMATIONS)
        if spacing is not None and not (math.isfinite(spacing) and spacing > 0):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"spacing must be > 0 m, got {spacing}")

        def do() -> dict[str, Any]:
            group = self._group(robots)
            out: dict[str, Any] = {"command": command, "robots": group, "time": self.world.time}
            if command == "stop":
                for r in group:
                    self.control.release(r, "fleet stop")
                    self.safety.manual.pop(r, None)
                return out
            if command == "sync":
                barrier = Barrier.new(tuple(group))
                self.barriers[barrier.id] = barrier
                params = {"barrier": barrier.id} | ({"timeout_s": timeout_s} if timeout_s else {})
                for r in group:
                    barrier.tasks[r] = self._submit(r, "sync", params, priority, client, queue=True)
                self._forget_released_barriers()
                return out | {"barrier": barrier.id, "tasks": dict(barrier.tasks)}
            goals = self._goals(command, group, target, formation, spacing)
            tasks = {r: self._submit(r, "go_to", {"goal": g, "align_yaw": True}, priority, client, queue)
                     for r, g in goals.items()}
            return out | {"tasks": tasks, "goals": {r: {"x": round(g.x, 4), "y": round(g.y, 4), "yaw": round(g.yaw, 4)}
                                                    for r, g in goals.items()}}

        return self.call(do)

    def _group(self, robots: list[str] | None) -> list[str]:
        group = self.registry.names() if robots is None else list(dict.fromkeys(robots))
        for r in group:
            self.registry.get(r)
        if not group:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, "no robots to command", "spawn robots first")
        return group

    def _goals(self, command: str, group: list[str], target: Pose2D | None, kind: str | None,
               spacing: float | None) -> dict[str, Pose2D]:
        if command == "return_home":
            return {r: self.registry.get(r).home for r in group}
        t = self.world.table
        idx = [t.index(r) for r in group]
        xy = np.column_stack([t.f["x"][idx], t.f["y"][idx]])
        here = Pose2D(float(xy[:, 0].mean()), float(xy[:, 1].mean()), heading_mean(t.f["yaw"][idx]))
        last = next((f for f in reversed(self.formations) if set(group) <= set(f.robots)), None)
        centre = target or here
        if command == "move" and kind is None:  # keep the shape the group is in
            offsets = last.offsets_of(group) if last is not None else to_frame(xy, here)
            kind = last.kind if last is not None else "as_is"
            spacing = last.spacing if last is not None else 0.0
        else:
            kind = kind or (last.kind if last is not None else "grid")
            spacing = spacing or (last.spacing if last is not None else 1.5)
            if kind == "random":
                spec = self.world.robot_spec(group[0])
                offsets = to_frame(random_slots(len(group), centre, spacing * math.sqrt(len(group)) + spacing,
                                                spacing, self._free_fn(spec.footprint_radius), self.world.rng,
                                                np.zeros((0, 2))), centre)
            else:
                offsets = formation_offsets(kind, len(group), spacing)
        slots = to_world(offsets, centre)
        radius = float(t.f["radius"][idx].max())
        others = {n: (float(t.f["x"][i]), float(t.f["y"][i])) for i, n in enumerate(t.names) if n not in group}
        check_slots(slots, self._free_fn(radius), 2 * radius + SEPARATION_MARGIN, others)
        perm = assign_slots(xy, slots)
        self._remember(Formation(kind, spacing, centre.yaw, tuple(group), offsets[perm]))
        return {r: Pose2D(float(slots[perm[k], 0]), float(slots[perm[k], 1]), centre.yaw) for k, r in enumerate(group)}

    def _submit(self, robot: str, type_name: str, params: dict[str, Any], priority: int, client: str,
                queue: bool) -> str:
        holder = self.safety.holder(robot)
        if holder is not None and holder != client:
            raise FleetError(ErrorCode.LEASE_HELD, f"robot '{robot}' is controlled by client '{holder}'",
                             "wait for its lease to lapse or ask that client to release it")
        if not queue:
            self.control.release(robot, f"superseded by a fleet {type_name}")
        self.safety.manual.pop(robot, None)
        return self.tasks.submit(type_name, robot, params, priority=priority).id

    def _forget_released_barriers(self) -> None:
        for bid in [b for b, bar in self.barriers.items()
                    if all(self.tasks.tasks.get(t) is None or self.tasks.tasks[t].state.done
                           for t in bar.tasks.values())]:
            del self.barriers[bid]

    # ---- swarm behaviours -------------------------------------------------------------------------------

    def behaviour_types(self) -> list[str]:
        return behaviour_names()

    def start_behaviour(self, type_name: str, robots: list[str] | None = None, params: dict[str, Any] | None = None,
                        *, client: str = "default") -> dict[str, Any]:
        """Start a swarm behaviour (flocking, coverage, formation, leader_follower, rendezvous) on robots."""

        def do() -> dict[str, Any]:
            group = self._group(robots)
            for r in group:
                holder = self.safety.holder(r)
                if holder is not None and holder != client:
                    raise FleetError(ErrorCode.LEASE_HELD, f"robot '{r}' is controlled by client '{holder}'")
            return self.behaviours.start(type_name, group, params).to_dict()

        return self.call(do)

    def stop_behaviour(self, behaviour_id: str) -> dict[str, Any]:
        return self.call(lambda: self.behaviours.stop(behaviour_id).to_dict())

    def behaviour_status(self, behaviour_id: str | None = None, history: bool = False) -> Any:
        """One behaviour's state and outcome metrics (with the per-second history), or all of them."""
        if behaviour_id is None:
            return self.call(lambda: [b.to_dict() for b in self.behaviours.running.values()])
        return self.call(lambda: self.behaviours.get(behaviour_id).to_dict(with_history=history))

    # ---- avoidance and deadlocks ------------------------------------------------------------------------

    def avoidance_settings(self) -> dict[str, Any]:
        return self.call(lambda: self.avoidance.settings())

    def set_avoidance(self, type_name: str | None = None, **settings: Any) -> dict[str, Any]:
        """Switch the avoidance plugin or change its settings (time_horizon, neighbor_dist, max_neighbors...)."""

        def do() -> dict[str, Any]:
            current = self.avoidance.settings()
            if type_name is None or type_name == current["type"]:
                spec = {**current, **settings}
            else:
                spec = {"type": type_name, **settings}
            self.avoidance = make_avoidance(spec)
            self.control.avoidance = self.avoidance
            self.events.publish(self.world.time, "avoidance_changed", (), f"avoidance: {spec['type']}",
                                settings=self.avoidance.settings())
            return self.avoidance.settings()

        return self.call(do)

    def deadlock_report(self) -> dict[str, Any]:
        """Deadlocks detected, resolved and open, with the robots involved and the policy used."""
        return self.call(self.deadlocks.report)

    def configure_deadlocks(self, **settings: Any) -> dict[str, Any]:
        """Change the deadlock policy (priority | replan | none) or its thresholds."""

        def do() -> dict[str, Any]:
            cfg = _validated(DeadlockConfig, {**self.deadlocks.config.model_dump(), **settings}, "deadlock")
            self.deadlocks.config = cfg
            return cfg.model_dump()

        return self.call(do)


def _validated(model: type[DeadlockConfig], data: dict[str, Any], section: str) -> DeadlockConfig:
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise FleetError(ErrorCode.INVALID_CONFIG, f"{section} settings: {summarize(exc)}",
                         f"fields: {', '.join(model.model_fields)}") from exc
