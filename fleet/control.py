"""The control loop, run every control period on the sim thread: who drives each robot, multi-robot
avoidance, the safety envelope, then the world; after each physics step: battery and collision events."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from scipy.spatial import cKDTree

if TYPE_CHECKING:
    from fleet.fleet_view import FleetView
    from fleet.service import FleetService

Command = tuple[float, float]


class ControlSource(Protocol):
    """Something that drives robots each control tick: the task manager, the behaviour manager."""

    def commands(self, now: float) -> dict[str, Command]: ...

    def owner(self, robot: str) -> str | None: ...

    def active_count(self) -> int: ...

    def cancel_all(self, reason: str) -> None: ...

    def release(self, robot: str, reason: str) -> None: ...


class VelocityFilter(Protocol):
    """Multi-robot avoidance: adjusts desired velocities so robots keep clear of each other."""

    def filter(self, view: FleetView, desired: dict[str, Command]) -> dict[str, Command]: ...


class ControlLoop:
    def __init__(self, service: FleetService) -> None:
        self.service = service
        self.sources: list[ControlSource] = []
        self.avoidance: VelocityFilter | None = None
        self.last_desired: dict[str, Command] = {}
        self._in_collision: set[str] = set()
        self._near: set[tuple[str, str]] = set()
        self.stats = {"collisions": 0, "near_misses": 0}

    def add_source(self, source: ControlSource) -> None:
        self.sources.append(source)

    def owner(self, robot: str) -> str:
        for s in self.sources:
            o = s.owner(robot)
            if o is not None:
                return o
        return "manual" if robot in self.service.safety.manual else "idle"

    def active_count(self) -> int:
        return sum(s.active_count() for s in self.sources)

    def cancel_all(self, reason: str) -> None:
        for s in self.sources:
            s.cancel_all(reason)

    def release(self, robot: str, reason: str) -> None:
        """Whatever drives `robot` lets go of it (a manual takeover, a removal, an e-stop)."""
        for s in self.sources:
            s.release(robot, reason)

    def apply_manual(self, robot: str) -> None:
        """A manual command takes effect at the next physics step, not the next control tick: it goes through
        the safety envelope (e-stop, geofence) into the world's command now. Avoidance, when configured, filters
        it with everyone else's at the next tick (≤ one control period later)."""
        svc = self.service
        world = svc.world
        m = svc.safety.active_manual(robot, world.time)
        if m is None or any(s.owner(robot) is not None for s in self.sources):
            return  # autonomy drives this robot: the tick decides
        i, f = world.table.index(robot), world.table.f
        gv, gw, why = svc.safety.gate(robot, m.v, m.w, float(f["x"][i]), float(f["y"][i]), float(f["yaw"][i]))
        if why == "e-stop":
            world.emergency_stop(robot)
        else:
            world.set_cmd_vel(robot, gv, gw)

    # ---- the tick --------------------------------------------------------------------------------------

    def tick(self) -> None:
        svc = self.service
        world, safety = svc.world, svc.safety
        now = world.time
        desired: dict[str, Command] = {}
        for source in self.sources:  # 1. autonomy: tasks, then behaviours
            for robot, cmd in source.commands(now).items():
                desired.setdefault(robot, cmd)
        for robot in world.table.names:  # 2. manual commands for robots autonomy does not drive
            if robot not in desired:
                m = safety.active_manual(robot, now)  # None once the deadman lapsed
                desired[robot] = (m.v, m.w) if m is not None else (0.0, 0.0)
        if self.avoidance is not None and len(desired) > 1:  # 3. keep clear of each other
            # Robots of an exclusive source (the traffic layer) are kept apart by it: avoidance leaves them be.
            fixed = {r: desired.pop(r) for r in list(desired)
                     if any(getattr(s, "exclusive", False) and s.owner(r) is not None for s in self.sources)}
            desired = self.avoidance.filter(svc.view, desired) if len(desired) > 1 else desired
            desired.update(fixed)
        self.last_desired = desired
        f = world.table.f
        rows, vs, ws = [], [], []
        for robot, (v, w) in desired.items():  # 4. the envelope gates everything
            i = world.table.index(robot)
            gv, gw, why = safety.gate(robot, v, w, float(f["x"][i]), float(f["y"][i]), float(f["yaw"][i]))
            if why == "e-stop":
                world.emergency_stop(robot)
            else:
                rows.append(i)
                vs.append(gv)
                ws.append(gw)
        if rows:  # the fleet's commands in one call, by the rows already looked up
            world.set_cmd_vels(np.array(rows, dtype=np.int64), vs, ws)
        self._near_misses(now)

    def after_step(self, before: tuple[np.ndarray, np.ndarray]) -> None:
        svc = self.service
        t = svc.world.table
        if not len(t):
            return
        f = t.f
        travelled = np.hypot(f["x"] - before[0], f["y"] - before[1])
        xy = np.column_stack([f["x"], f["y"]])
        for i in svc.battery.update(svc.world.dt, travelled, xy, f["v"]):
            name = t.names[int(i)]
            svc.events.publish(svc.world.time, "low_battery", (name,), f"{name} battery below "
                               f"{svc.config.battery.low_threshold:.0%}", soc=float(svc.battery.soc[int(i)]))
        hit = {t.names[i] for i in np.flatnonzero(t.b["in_collision"])}
        for name in hit - self._in_collision:  # edge-triggered: one event per contact episode
            others = sorted({c.other for c in svc.world.latest_contacts(name).contacts})
            self.stats["collisions"] += 1
            svc.events.publish(svc.world.time, "collision", (name,), f"{name} hit {', '.join(others) or 'something'}",
                               others=others)
        self._in_collision = hit

    def _near_misses(self, now: float) -> None:
        svc = self.service
        t = svc.world.table
        if len(t) < 2:
            return
        xy = np.column_stack([t.f["x"], t.f["y"]])
        r = t.f["radius"]
        reach = 2 * float(r.max()) + svc.config.near_miss_distance
        pairs = cKDTree(xy).query_pairs(reach, output_type="ndarray")
        current: set[tuple[str, str]] = set()
        for a, b in pairs:
            gap = float(np.hypot(*(xy[a] - xy[b]))) - r[a] - r[b]
            if gap < svc.config.near_miss_distance:
                current.add((t.names[a], t.names[b]))
        for pair in current - self._near:
            self.stats["near_misses"] += 1
            svc.events.publish(now, "near_miss", pair, f"{pair[0]} and {pair[1]} within "
                               f"{svc.config.near_miss_distance} m")
        self._near = current

    def describe(self) -> dict[str, Any]:
        return {"sources": [type(s).__name__ for s in self.sources],
                "avoidance": type(self.avoidance).__name__ if self.avoidance else None, **self.stats}
