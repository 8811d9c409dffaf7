"""The traffic layer: robots on a known map move cell to cell in synchronous PIBT steps (fleet/traffic/pibt.py),
so they cannot collide with each other or deadlock; ORCA stays for robots outside the layer.

A step is planned for all robots at once, then executed in two phases over all robots in numpy:
  turn  movers rotate in place to face their next cell (their footprint stays inside their own cell);
  move  movers travel one cell along a smooth synchronous profile, tracked by feedback. A robot entering a
        cell another robot is leaving straight ahead starts with it (they stay a cell apart); behind a robot
        that turns away it starts half a traverse later (it stays ≥ one cell from it). Rotations of robots
        around a loop are never planned (pibt.py), so every follower has a leader that started first.
With cells wider than a robot's footprint diameter, any two robots stay ≥ about one cell apart at all times.
A robot that makes no progress towards its goal for `stall_s` raises a deadlock event naming it and the
robots in its way; the event closes (with its duration) when its priority, which grows while it waits,
has carried it closer (PIBT's guarantee).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from fleet.traffic.grid import TrafficGrid
from fleet.traffic.pibt import PIBT
from sim.errors import ErrorCode, FleetError
from sim.transforms import wrap_angles

if TYPE_CHECKING:
    from fleet.service import FleetService

TURN_TOL = 0.03  # rad: movers face their next cell within this before the move phase
ARRIVE_TOL = 0.06  # m: movers this close to their cell centre end the move phase
SETTLE_S = 1.5  # s: longest wait for stragglers after the profile ends


class TrafficManager:
    """A ControlSource driving the robots given to it (`add`) to goals (`go`) on a TrafficGrid."""

    exclusive = True  # its robots' commands skip velocity avoidance (the layer already keeps them apart)

    def __init__(self, service: FleetService, *, cell: float = 1.0, speed: float = 0.45, seed: int = 0,
                 stall_s: float = 10.0) -> None:
        self.service = service
        spec = service.default_spec()
        self.radius = spec.footprint_radius
        if 2 * self.radius + 0.1 > cell:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"traffic cell {cell} m is too small for a robot of "
                             f"radius {self.radius:.3f} m", f"use cell ≥ {2 * self.radius + 0.1:.2f} m")
        self.grid = TrafficGrid(service.static_clearance(), service.world.description.bounds(), cell, self.radius)
        self.pibt = PIBT(self.grid.neighbours, self.grid.fields.to, seed)
        self.traverse_s = cell / speed  # one cell, smoothstep profile: peak speed 1.5 × `speed`
        self.max_w = min(1.5, spec.limits.max_angular)
        self.stall_s = stall_s
        self.names: list[str] = []
        self.cur = np.zeros(0, np.int64)
        self.nxt = np.zeros(0, np.int64)
        self.goal = np.full(0, -1, np.int64)
        self.since = np.zeros(0)  # sim time the current goal was given (priority)
        self.best = np.zeros(0)  # best distance to goal so far, and when it was reached
        self.best_at = np.zeros(0)
        self.pending = np.zeros(0, bool)  # a goal given and not reached yet
        self.offset = np.zeros(0)
        self.phase = "plan"
        self.t0 = 0.0
        self.on_reached: Callable[[str, float], None] | None = None
        self.open_stalls: dict[str, tuple[float, list[str]]] = {}
        self.stats: dict[str, Any] = {"steps": 0, "reached": 0, "deadlocks": 0, "resolved": 0,
                                      "longest_deadlock_s": 0.0, "pushes": 0}
        self._tie = np.random.default_rng(seed).random(0)

    # ---- robots and goals --------------------------------------------------------------------------------

    def add(self, robot: str) -> None:
        """Hand a robot to the layer: it must stand at rest near the centre of a free, unclaimed cell."""
        w = self.service.world
        p = w.robot_pose(robot)
        node = self.grid.node_at(p.x, p.y)
        if node < 0 or math.hypot(*(self.grid.xy[node] - (p.x, p.y))) > 0.2 or node in self.cur.tolist():
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"robot '{robot}' is not at a free traffic cell centre",
                             "spawn it at TrafficManager.grid.xy[node] (one robot per cell)")
        self.names.append(robot)
        self.cur = np.append(self.cur, node)
        self.nxt = np.append(self.nxt, node)
        self.goal = np.append(self.goal, node)
        now = w.time
        self.since, self.best, self.best_at = (np.append(a, v) for a, v in
                                               ((self.since, now), (self.best, 0.0), (self.best_at, now)))
        self.offset = np.append(self.offset, 0.0)
        self.pending = np.append(self.pending, False)
        self._tie = np.append(self._tie, np.random.default_rng(len(self.names)).random() * 1e-3)

    def go(self, robot: str, x: float, y: float) -> int:
        """Send a robot to the free cell nearest (x, y); returns the goal node."""
        i = self.names.index(robot)
        node = self.grid.node_at(x, y)
        self.goal[i] = node if node >= 0 else self.grid.nearest_node(x, y)
        self.since[i] = self.best_at[i] = self.service.world.time
        self.best[i] = self.grid.fields.to(int(self.goal[i]))[self.cur[i]]
        self.pending[i] = self.goal[i] != self.cur[i]
        if not np.isfinite(self.best[i]):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"goal ({x:.2f}, {y:.2f}) is not reachable from "
                             f"'{robot}' on the traffic grid", "pick a goal in the same free region")
        return int(self.goal[i])

    # ---- ControlSource -----------------------------------------------------------------------------------

    def owner(self, robot: str) -> str | None:
        return "traffic" if robot in self.names else None

    def active_count(self) -> int:
        return int(np.count_nonzero(self.goal != self.cur))

    def cancel_all(self, reason: str) -> None:
        self.goal = self.cur.copy()

    def release(self, robot: str, reason: str) -> None:
        """A robot leaves the layer only between steps, at rest in its cell (else the others' safety breaks)."""
        if robot in self.names and self.phase == "plan":
            i = self.names.index(robot)
            self.names.pop(i)
            for attr in ("cur", "nxt", "goal", "since", "best", "best_at", "offset", "pending", "_tie"):
                setattr(self, attr, np.delete(getattr(self, attr), i))

    def commands(self, now: float) -> dict[str, tuple[float, float]]:
        if not self.names:
            return {}
        if self.phase == "plan":
            self._plan(now)
        f, rows = self.service.world.table.f, [self.service.world.table.index(n) for n in self.names]
        x, y, yaw = f["x"][rows], f["y"][rows], f["yaw"][rows]
        c, n = self.grid.xy[self.cur], self.grid.xy[self.nxt]
        moving = self.nxt != self.cur
        d = n - c
        heading = np.where(moving, np.arctan2(d[:, 1], d[:, 0]), yaw)
        err = wrap_angles(heading - yaw)
        v, w = np.zeros(len(rows)), np.zeros(len(rows))
        if self.phase == "turn":
            w = np.clip(4.0 * err, -self.max_w, self.max_w) * moving
            if np.all(np.abs(err[moving]) < TURN_TOL):
                self.phase, self.t0 = "move", now
        if self.phase == "move":
            u = np.clip((now - self.t0) / self.traverse_s - self.offset, 0.0, 1.0)
            s, ds = 3 * u ** 2 - 2 * u ** 3, 6 * u * (1 - u) / self.traverse_s
            ref = c + s[:, None] * d
            unit = d / self.grid.cell
            along = (ref[:, 0] - x) * unit[:, 0] + (ref[:, 1] - y) * unit[:, 1]
            cross = -(ref[:, 0] - x) * unit[:, 1] + (ref[:, 1] - y) * unit[:, 0]
            v = np.where(moving, ds * self.grid.cell + 2.0 * along, 0.0)
            w = np.where(moving, np.clip(4.0 * err + 3.0 * cross, -self.max_w, self.max_w), 0.0)
            end = self.t0 + (1.0 + float(self.offset.max())) * self.traverse_s
            arrived = np.hypot(n[:, 0] - x, n[:, 1] - y) < ARRIVE_TOL
            if now >= end and (np.all(arrived | ~moving) or now >= end + SETTLE_S):
                self.cur = self.nxt.copy()
                self.phase = "plan"
                v[:], w[:] = 0.0, 0.0
                self._arrivals(now)
        return {name: (float(a), float(b)) for name, a, b in zip(self.names, v, w, strict=True)}

    # ---- planning and bookkeeping ------------------------------------------------------------------------

    def _plan(self, now: float) -> None:
        priority = (now - self.since) * (self.goal != self.cur) + self._tie
        self.nxt = np.asarray(self.pibt.step(self.cur.tolist(), self.goal.tolist(), priority), np.int64)
        self.stats["steps"] += 1
        self.stats["pushes"] += len(self.pibt.pushes)
        self.offset = self._offsets()
        self._stalls(now)
        if np.any(self.nxt != self.cur):
            self.phase = "turn"

    def _offsets(self) -> np.ndarray:
        """Start delays (in traverses): behind a leader that turns away, half a traverse after it starts."""
        occ = {int(v): i for i, v in enumerate(self.cur.tolist())}
        off = np.full(len(self.cur), -1.0)

        def of(i: int) -> float:
            if off[i] < 0:
                k = occ.get(int(self.nxt[i]))
                if k is None or k == i or self.nxt[i] == self.cur[i]:
                    off[i] = 0.0
                else:
                    same = np.array_equal(self.grid.xy[self.nxt[k]] - self.grid.xy[self.cur[k]],
                                          self.grid.xy[self.nxt[i]] - self.grid.xy[self.cur[i]])
                    off[i] = of(k) + (0.0 if same else 0.5)
            return float(off[i])

        for i in range(len(self.cur)):
            of(i)
        return off

    def _arrivals(self, now: float) -> None:
        for i in np.flatnonzero((self.cur == self.goal) & self.pending).tolist():
            self.pending[i] = False
            self.stats["reached"] += 1
            if self.on_reached is not None:
                self.on_reached(self.names[i], now)

    def _stalls(self, now: float) -> None:
        """Deadlock events: robots whose distance to goal has not improved for stall_s, and who is in the way."""
        dist = np.array([self.grid.fields.to(int(g))[c] for g, c in zip(self.goal, self.nxt, strict=True)])
        better = (dist < self.best) | (dist == 0)  # at its goal counts as progress (it may be pushed off later)
        self.best = np.where(better, dist, self.best)
        self.best_at = np.where(better, now, self.best_at)
        svc = self.service
        for i in np.flatnonzero(better).tolist():
            name = self.names[i]
            if name in self.open_stalls:
                start, others = self.open_stalls.pop(name)
                took = now - start + self.stall_s
                self.stats["resolved"] += 1
                self.stats["longest_deadlock_s"] = max(self.stats["longest_deadlock_s"], took)
                svc.events.publish(now, "deadlock_resolved", (name, *others), f"{name} moving towards its goal "
                                   f"again after {took:.1f} s: priority inheritance (PIBT) cleared the way",
                                   strategy="pibt_priority_inheritance", duration=took)
        stuck = (now - self.best_at >= self.stall_s) & (self.goal != self.cur)
        occ = {int(v): i for i, v in enumerate(self.cur.tolist())}
        for i in np.flatnonzero(stuck).tolist():
            name = self.names[i]
            if name in self.open_stalls:
                continue
            field = self.grid.fields.to(int(self.goal[i]))
            ahead = [v for v in self.grid.neighbours[int(self.cur[i])] if field[v] < field[self.cur[i]]]
            others = sorted({self.names[occ[v]] for v in ahead if v in occ})
            self.open_stalls[name] = (now, others)
            self.stats["deadlocks"] += 1
            svc.events.publish(now, "deadlock", (name, *others), f"{name} has not come closer to its goal for "
                               f"{self.stall_s:g} s; blocked by {', '.join(others) or 'nobody (waiting its turn)'}; "
                               "resolution: its priority grows until PIBT pushes the others aside",
                               strategy="pibt_priority_inheritance")

    def describe(self) -> dict[str, Any]:
        return {"robots": len(self.names), "cells": len(self.grid), "cell_m": self.grid.cell,
                "fields_computed": self.grid.fields.computed, "open_deadlocks": len(self.open_stalls), **self.stats}
