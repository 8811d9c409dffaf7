"""The traffic layer: robots on a known map move cell to cell in synchronous PIBT steps (fleet/traffic/pibt.py),
so they cannot collide with each other or deadlock; ORCA stays for robots outside the layer.

A step is planned for all robots at once (PIBT), then executed per robot in numpy: a mover turns in place to
face its next cell (or its back, for a cell behind: it reverses), then travels one cell on a trapezoidal
reference (at rest at both centres, so it never overshoots), tracked by feedback. A robot entering a cell
another robot is leaving starts no earlier than that leader (straight on), or half a traverse after it (when
the leader turns away), so it stays about a cell behind. Rotations of robots around a loop are never planned
(pibt.py): leaders form a forest and every follower's leader starts first. The next step is planned when
every mover has arrived.
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

TURN_TOL = 0.05  # rad: movers face their next cell within this before the move phase
ARRIVE_TOL = 0.12  # m: movers this close to their cell centre end the move phase (the next step may go on)


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
        # One cell on a trapezoidal profile (accelerate, cruise, brake to rest at the centre): a robot never
        # overshoots into the next cell, whatever comes after.
        self.accel = min(1.0, spec.limits.max_linear_accel * 0.7)
        self.peak = min(speed, math.sqrt(self.accel * cell))
        ramp = self.peak / self.accel
        self.traverse_s = 2 * ramp + (cell - self.peak * ramp) / self.peak
        self.max_w = min(2.0, spec.limits.max_angular)
        self.stall_s = stall_s
        self.names: list[str] = []
        self.cur = np.zeros(0, np.int64)
        self.nxt = np.zeros(0, np.int64)
        self.goal = np.full(0, -1, np.int64)
        self.since = np.zeros(0)  # sim time the current goal was given (priority)
        self.best = np.zeros(0)  # best distance to goal so far, and when it was reached
        self.best_at = np.zeros(0)
        self.pending = np.zeros(0, bool)  # a goal given and not reached yet
        self.leader = np.zeros(0, np.int64)
        self.delay = np.zeros(0)
        self.start = np.zeros(0)
        self.phase = "plan"
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
            for attr in ("cur", "nxt", "goal", "since", "best", "best_at", "pending", "_tie"):
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
        back = np.abs(err) > math.pi / 2  # a cell behind: drive there in reverse rather than turn round
        err = np.where(back, wrap_angles(err + math.pi), err)
        sign = np.where(back, -1.0, 1.0)
        if self.phase == "move":
            # Each mover starts once it faces its cell and its leader (the robot leaving that cell) has started
            # (straight on: with it; turning away: half a traverse later). Leaders form a forest (pibt.py).
            waiting = moving & ~np.isfinite(self.start)
            for i in np.flatnonzero(waiting & (np.abs(err) < TURN_TOL)).tolist():
                k = int(self.leader[i])
                if k < 0 or (np.isfinite(self.start[k]) and now >= self.start[k] + self.delay[i] * self.traverse_s):
                    self.start[i] = now
        started = moving & np.isfinite(self.start)
        s, ds = self._profile(np.where(started, now - np.where(started, self.start, now), 0.0))
        ref = c + s[:, None] * d
        unit = d / self.grid.cell
        along = (ref[:, 0] - x) * unit[:, 0] + (ref[:, 1] - y) * unit[:, 1]
        cross = -(ref[:, 0] - x) * unit[:, 1] + (ref[:, 1] - y) * unit[:, 0]
        v = np.where(started, sign * (ds * self.grid.cell + 2.0 * along), 0.0)
        w = np.where(moving, np.clip(4.0 * err + 3.0 * cross * started, -self.max_w, self.max_w), 0.0)
        arrived = np.hypot(n[:, 0] - x, n[:, 1] - y) < ARRIVE_TOL
        done = ~moving | (started & (now >= self.start + self.traverse_s) & arrived)
        if done.all():  # never plan from a cell a robot has not reached
            self.cur = self.nxt.copy()
            self.phase = "plan"
            v[:], w[:] = 0.0, 0.0
            self._arrivals(now)
        return {name: (float(a), float(b)) for name, a, b in zip(self.names, v, w, strict=True)}

    def _profile(self, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Share of the cell travelled and its rate (1/s) at time `tau` into the traverse (trapezoid)."""
        a, vp, T, L = self.accel, self.peak, self.traverse_s, self.grid.cell
        ramp = vp / a
        tau = np.clip(tau, 0.0, T)
        dist = np.where(tau < ramp, 0.5 * a * tau ** 2,
                        np.where(tau < T - ramp, 0.5 * vp * ramp + vp * (tau - ramp), L - 0.5 * a * (T - tau) ** 2))
        vel = np.where(tau < ramp, a * tau, np.where(tau < T - ramp, vp, a * (T - tau)))
        return np.clip(dist / L, 0.0, 1.0), vel / L

    # ---- planning and bookkeeping ------------------------------------------------------------------------

    def _plan(self, now: float) -> None:
        priority = (now - self.since) * (self.goal != self.cur) + self._tie
        self.nxt = np.asarray(self.pibt.step(self.cur.tolist(), self.goal.tolist(), priority), np.int64)
        self.stats["steps"] += 1
        self.stats["pushes"] += len(self.pibt.pushes)
        self.leader, self.delay = self._leaders()
        self.start = np.full(len(self.cur), np.inf)
        self._stalls(now)
        if np.any(self.nxt != self.cur):
            self.phase = "move"

    def _leaders(self) -> tuple[np.ndarray, np.ndarray]:
        """Per mover, the robot leaving the cell it enters (-1: none) and the start delay behind it, in
        traverses: 0 straight on, 0.5 when the leader turns away."""
        occ = {int(v): i for i, v in enumerate(self.cur.tolist())}
        leader = np.full(len(self.cur), -1, np.int64)
        delay = np.zeros(len(self.cur))
        for i in np.flatnonzero(self.nxt != self.cur).tolist():
            k = occ.get(int(self.nxt[i]))
            if k is not None and k != i:
                leader[i] = k
                same = np.array_equal(self.grid.xy[self.nxt[k]] - self.grid.xy[self.cur[k]],
                                      self.grid.xy[self.nxt[i]] - self.grid.xy[self.cur[i]])
                delay[i] = 0.0 if same else 0.5
        return leader, delay

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
