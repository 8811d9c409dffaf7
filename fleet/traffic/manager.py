"""The traffic layer: robots on a known map move cell to cell along a PIBT plan (fleet/traffic/pibt.py),
executed asynchronously through an action-dependency graph (schedule.py), so they cannot collide with each
other or wait on each other in a cycle; ORCA stays for robots outside the layer.

Planning: PIBT plans steps on the planned configuration (the robots' last planned cells), at most one per
control tick, whenever some robot with a goal has nothing queued; robots with `window` moves queued already plan
no move of their own (bounded look-ahead, fresh plans for new goals) but can still be pushed — one more move
appended — so the highest-priority robot is never held by a robot that merely has a move queued, and a follower
extends its leader's plan (a frozen robot pushed by a lower-priority chain may only move on: pibt.py).
Execution (execution.py, motion.py): each robot claims its next planned cell
as soon as the schedule lets it (first in the cell's FIFO, nobody in or entering it), turns to face it (or
reverses into a cell behind), and drives there on a braking-limited profile that keeps `gap` from the robot
leaving that cell, by ground truth (motion.py); a straight run continues through cell centres without
stopping when the next cell is already claimed. No fleet-wide barrier: a robot waits only for the robots
whose cells it needs, so slow or delayed robots hold up only those behind them.

Waits (stalls.py): a robot that has not come closer to its goal for `stall_s` raises a `deadlock` event naming it
and the robots it waits for, with the resolution; `deadlock_resolved` reports when it moves closer again and how
long it took. The ADG is acyclic, so no wait is a cycle; PIBT's growing priorities end waits on graphs where every
edge lies on a cycle, but robots can be pushed back and forth for a long time, and in dead ends PIBT can oscillate
(pibt.py, docs/fleet.md). Against long waits: lanes (grid.py, lanes.py: moves against a row's or column's direction
cost `highway` times more; one-lane through corridors are one-way, `one_way`), aging (a robot without progress for
`urgent_s` outranks all that are not urgent until it is `urgent_cells` closer; among the urgent, the longest without
progress first; an urgent robot plans `urgent_window` moves ahead, priority.lookahead), crossings kept clear
(`keep_clear`, crossings.py), yielding aside (pibt.py), robots in a wait not pushed back (`hold_ground_s`,
priority.holding_ground), dispatch admission (`admission`, admission.py: new goals
held while the layer is congested; `bound`, the default, admission_wait.py: held robots wait on parking cells off
the main flow, parking.py, and keep off the ways of robots in a wait, `held_clear`) and, optionally,
congestion-aware routing (congestion.py). Withdrawing planned moves not yet started (`withdraw`, withdraw.py): by
default (`crowded`) all every `flush_s` while admission holds goals.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from fleet.traffic.admission import PARKED, held_mask, layer_admission
from fleet.traffic.admission_wait import held_off_ways
from fleet.traffic.congestion import CongestionFields
from fleet.traffic.crossings import bound_robots, crossing_cells
from fleet.traffic.execution import arrivals, claims, release_cleared
from fleet.traffic.grid import TrafficGrid
from fleet.traffic.motion import drive
from fleet.traffic.parking import Parking
from fleet.traffic.pibt import PIBT
from fleet.traffic.priority import URGENT, holding_ground, lookahead, priorities, urgent_room
from fleet.traffic.schedule import BIG, Schedule
from fleet.traffic.settings import check_settings
from fleet.traffic.stalls import close_stall, open_stalls
from fleet.traffic.withdraw import withdraw_step
from sim.errors import ErrorCode, FleetError

if TYPE_CHECKING:
    from fleet.service import FleetService

GAP_MARGIN = 0.1  # m: kept between the footprints of a follower and its leader (tracking error)


class TrafficManager:
    """A ControlSource driving the robots given to it (`add`) to goals (`go`) on a TrafficGrid."""

    exclusive = True  # its robots' commands skip velocity avoidance (the layer already keeps them apart)

    def __init__(self, service: FleetService, *, cell: float = 1.0, speed: float = 0.45, seed: int = 0,
                 stall_s: float = 10.0, window: int = 1, lane_cost: float = 3.0,
                 priority: Literal["goal_age", "since_progress"] = "goal_age", urgent_s: float | None = 10.0,
                 yield_aside: bool = True, highway: float = 4.0, push_frozen: bool = True,
                 congestion: float = 0.0, urgent_rank: Literal["since_progress", "since_urgent"] = "since_progress",
                 withdraw: Literal["off", "loops", "ahead", "both", "flush", "crowded"] = "crowded",
                 admission: Literal["off", "aimd", "park", "bound"] = "bound", urgent_cells: int | None = 3,
                 one_way: bool = True, record: bool = False, flush_s: float = 1.0, urgent_window: int = 1,
                 keep_clear: bool = True, keep_clear_s: float = 4.0, held_clear: bool = True,
                 hold_ground_s: float | None = 5.0) -> None:
        self.service = service
        spec = service.default_spec()
        self.radius = spec.footprint_radius
        self.gap = 2 * self.radius + GAP_MARGIN
        check_settings(cell=cell, gap=self.gap, radius=self.radius, priority=priority, window=window,
                       urgent_s=urgent_s, urgent_rank=urgent_rank, highway=highway, congestion=congestion,
                       withdraw=withdraw, flush_s=flush_s, admission=admission, urgent_cells=urgent_cells,
                       urgent_window=urgent_window, keep_clear_s=keep_clear_s, hold_ground_s=hold_ground_s)
        self.priority, self.window, self.stall_s, self.urgent_window = priority, window, stall_s, urgent_window
        self.urgent_s, self.urgent_rank, self.urgent_cells = urgent_s, urgent_rank, urgent_cells  # module doc
        self.keep_clear, self.keep_clear_s, self.held_clear = keep_clear, keep_clear_s, held_clear  # module doc
        self.hold_ground_s = hold_ground_s  # robots in a wait are not pushed back (priority.holding_ground)
        self.grid = TrafficGrid(service.static_clearance(), service.world.description.bounds(), cell, self.radius,
                                lane_cost=lane_cost, highway=highway, one_way=one_way)
        self.pibt = PIBT(self.grid.neighbours, self.grid.fields.to, seed)
        self.pibt.yield_aside, self.pibt.push_frozen = yield_aside, push_frozen
        self.pibt.traps = {v for chain in self.grid.one_way for v in chain}
        self.pibt.box = crossing_cells(self.grid.ij, self.grid.neighbours) if keep_clear else set()
        self.pibt.box_exempt = URGENT  # a robot kept out of a crossing enters once urgent (crossings.py)
        self.sched = Schedule(len(self.grid), record)
        # The profile brakes at 0.7 × the rated acceleration (at most 1 m/s²), so the tracking keeps up and a follower
        # stops where it planned, short of its leader (braking at the rated value: 26–59 contacts per 10-minute run);
        # it speeds up at the rated value: every start from rest is shorter, and a jam is mostly starts from rest
        # (docs/benchmarks-fleet.md, twenty-second landing).
        self.accel = min(1.0, spec.limits.max_linear_accel * 0.7) / cell  # braking, cells/s²
        self.accel_up = max(spec.limits.max_linear_accel / cell, self.accel)  # speeding up, cells/s²
        self.peak = speed / cell  # cells/s
        self.max_w = min(2.0, spec.limits.max_angular)
        # Congestion-aware routing (congestion.py): PIBT ranks a robot's next cells by fields with a toll on busy
        # cells; the waits reported keep the static fields.
        self.congestion = CongestionFields(self.grid.adjacency, congestion) if congestion > 0 else None
        if self.congestion is not None:
            self.pibt.field = self.congestion.to
        self.withdraw = withdraw  # unstarted moves withdrawn: loops, ahead of urgent robots, all (withdraw.py)
        self.flush_s, self._flush_at = flush_s, 0.0
        self.admission = layer_admission(admission, stall_s, len(self.grid))  # new goals held while congested
        self.parking = Parking(self.grid) if admission in PARKED else None  # held robots wait off the main flow
        self.names: list[str] = []
        self._idx: dict[str, int] = {}
        ints, floats = ("a", "b", "claim", "seg_step", "claim_step", "goal"), ("s", "sd", "sign", "since",
                                                                            "best", "best_at", "hold", "scale",
                                                                            "urgent_at", "urgent_d", "rest_at")
        for k in ints:
            setattr(self, k, np.zeros(0, np.int64))
        for k in floats:
            setattr(self, k, np.zeros(0))
        self.a: np.ndarray  # cell being left (= b at rest)
        self.b: np.ndarray  # cell being entered
        self.claim: np.ndarray  # next cell, claimed while still moving (straight on), or -1
        self.seg_step: np.ndarray  # plan step of the move under way (BIG at rest)
        self.claim_step: np.ndarray
        self.goal: np.ndarray
        self.s: np.ndarray  # progress a → b (and on into claim), cells
        self.sd: np.ndarray
        self.sign: np.ndarray  # -1 when reversing into a cell behind
        self.since: np.ndarray  # sim time the goal was given (PIBT priority)
        self.best: np.ndarray  # best distance to goal so far (hops), and when
        self.best_at: np.ndarray
        self.hold: np.ndarray  # sim time until which a robot is held (delayed) where it is
        self.scale: np.ndarray  # per-robot speed factor
        self.urgent_at: np.ndarray  # sim time a robot became urgent (waited urgent_s), +inf when it is not
        self.urgent_d: np.ndarray  # its best distance to goal then (cells)
        self.rest_at: np.ndarray  # sim time it last came to rest (crossings.bound_robots)
        self.released = np.zeros(0, bool)
        self.pending = np.zeros(0, bool)  # a goal given and not reached yet
        self._tie = np.zeros(0)
        self._last: float | None = None
        self.on_reached: Callable[[str, float], None] | None = None
        self.open_stalls: dict[str, tuple[float, list[str], str]] = {}
        self.stats: dict[str, Any] = {"steps": 0, "moves": 0, "reached": 0, "deadlocks": 0, "resolved": 0,
                                      "longest_deadlock_s": 0.0, "pushes": 0, "ticks": 0, "cpu_s": 0.0, "withdrawn": 0}

    # ---- robots and goals --------------------------------------------------------------------------------

    def add(self, robot: str) -> None:
        """Hand a robot to the layer: it must stand at rest near the centre of a free, unclaimed cell."""
        w = self.service.world
        p = w.robot_pose(robot)
        node = self.grid.node_at(p.x, p.y)
        if node < 0 or math.hypot(*(self.grid.xy[node] - (p.x, p.y))) > 0.2 or self.sched.at[node] >= 0 \
                or robot in self._idx:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"robot '{robot}' is not at a free traffic cell centre",
                             "spawn it at TrafficManager.grid.xy[node] (one robot per cell)")
        self._idx[robot] = len(self.names)
        self.names.append(robot)
        self.sched.add(node)
        now = w.time
        row = {"a": node, "b": node, "claim": -1, "seg_step": BIG, "claim_step": BIG, "goal": node, "s": 0.0,
               "sd": 0.0, "sign": 1.0, "since": now, "best": 0.0, "best_at": now, "hold": -math.inf, "scale": 1.0,
               "urgent_at": math.inf, "urgent_d": 0.0, "rest_at": -math.inf,  # at rest long since
               "released": True, "pending": False,
               "_tie": np.random.default_rng(len(self.names)).random() * 1e-3}
        for k, v in row.items():
            setattr(self, k, np.append(getattr(self, k), v))

    def go(self, robot: str, x: float, y: float) -> int:
        """Send a robot to the free cell nearest (x, y); returns the goal node. With admission on, a goal given
        while the layer is congested is held (the robot stays idle, pushable) until admitted, in FIFO order."""
        node = self._goal_node(robot, x, y)
        adm, i = self.admission, self._idx[robot]
        if adm is not None and (adm.held(robot) or adm.must_hold(int(np.count_nonzero(self.pending)))):
            adm.hold(robot, x, y, self.service.world.time)
            self.goal[i], self.pending[i] = self._idle_goal(i, x, y), False
            return node
        return self._set_goal(i, node)

    def held(self, robot: str) -> bool:
        """The robot's goal is held by admission (not started yet)."""
        return self.admission is not None and self.admission.held(robot)

    def _idle_goal(self, i: int, x: float, y: float) -> int:
        """Where a held robot waits: its parking cell (parking.py; towards its held goal (x, y)), or where it is."""
        here, name = int(self.sched.tail[i]), self.names[i]
        if self.parking is None:
            return here
        kept = self.parking.kept(name)  # kept once given: no goal field needed on every tick
        return kept if kept is not None else self.parking.assign(name, here,
                                                                 self.grid.fields.to(self._goal_node(name, x, y)))

    def _goal_node(self, robot: str, x: float, y: float) -> int:
        i = self._idx[robot]
        node = self.grid.node_at(x, y)
        node = node if node >= 0 else self.grid.nearest_node(x, y)
        d = self.grid.fields.to(node)[self.a[i]]
        if not np.isfinite(d):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"goal ({x:.2f}, {y:.2f}) is not reachable from "
                             f"'{robot}' on the traffic grid", "pick a goal in the same free region")
        return node

    def _set_goal(self, i: int, node: int) -> int:
        self.goal[i] = node
        self.since[i] = self.best_at[i] = self.service.world.time
        self.best[i] = self.grid.fields.to(node)[self.a[i]]
        self.urgent_at[i] = math.inf
        self.pending[i] = node != self.a[i] or self.a[i] != self.b[i]
        return node

    def hold_robot(self, robot: str, seconds: float) -> None:
        """Delay a robot where it is (braking at the layer's deceleration) for `seconds` of sim time: a robot
        stopped for a pick, say. The others keep their order and their distance (the schedule)."""
        self.hold[self._idx[robot]] = self.service.world.time + seconds

    def set_speed_scale(self, robot: str, factor: float) -> None:
        """A robot slower (or faster) than the rest: its profile's peak speed times `factor` (0, 1]."""
        if not 0.0 < factor <= 1.0:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"speed factor must be in (0, 1], got {factor}")
        self.scale[self._idx[robot]] = factor

    @property
    def cells(self) -> np.ndarray:
        """Per robot, the cell it is in or leaving."""
        return self.a

    # ---- ControlSource -----------------------------------------------------------------------------------

    def owner(self, robot: str) -> str | None:
        return "traffic" if robot in self._idx else None

    def active_count(self) -> int:
        return int(np.count_nonzero(self.pending | (self.a != self.b)))

    def cancel_all(self, reason: str) -> None:
        """No new steps are planned; moves already scheduled still run (others depend on them)."""
        self.goal = self.sched.tail.copy()
        self.pending[:] = False
        if self.admission is not None:
            self.admission.queue.clear()
        if self.parking is not None:
            self.parking.clear()

    def release(self, robot: str, reason: str) -> None:
        """A robot leaves the layer only at rest with nothing scheduled (others' safety and order depend on it)."""
        i = self._idx.get(robot)
        if i is None or self.a[i] != self.b[i] or self.sched.queue[i] or self.sched.tail[i] != self.a[i]:
            return
        if self.admission is not None:
            self.admission.drop(robot)
        if self.parking is not None:
            self.parking.release(robot)
        self.sched.remove(i, int(self.a[i]))
        self.names.pop(i)
        self._idx = {n: k for k, n in enumerate(self.names)}
        for k in ("a", "b", "claim", "seg_step", "claim_step", "goal", "s", "sd", "sign", "since", "best",
                  "best_at", "hold", "scale", "urgent_at", "urgent_d", "rest_at", "released", "pending", "_tie"):
            setattr(self, k, np.delete(getattr(self, k), i))

    def commands(self, now: float) -> dict[str, tuple[float, float]]:
        if not self.names:
            return {}
        t0 = time.process_time()
        out = self._tick(now)
        self.stats["ticks"] += 1
        self.stats["cpu_s"] += time.process_time() - t0
        return out

    def _tick(self, now: float) -> dict[str, tuple[float, float]]:
        dt = 0.0 if self._last is None else min(max(now - self._last, 0.0), 0.5)
        self._last = now
        t = self.service.world.table
        rows = [t.index(n) for n in self.names]
        pos = np.column_stack([t.f["x"][rows], t.f["y"][rows]])
        yaw = t.f["yaw"][rows]
        release_cleared(self, pos)  # 1. cells left behind, once the footprint is clear (execution.py)
        arrivals(self, pos, now)  # 2. arrivals at the end of the segment
        if self.withdraw != "off":
            withdraw_step(self, now)
        claims(self, yaw)  # 3. next cells claimed when the schedule lets them
        if self.congestion is not None:
            self.congestion.observe(np.concatenate([self.a, self.b]), dt)
        # 4. profiles and commands (numpy over all robots)
        v, w = drive(self, now, dt, pos, yaw)
        # 5. plan one more PIBT step when someone with a goal has nothing queued; robots with `window` moves
        #    queued already plan no move of their own (bounded look-ahead; as in Causal-PIBT only robots ready to
        #    act initiate moves) but can be pushed, so a slow robot holds up only the robots that need its cells.
        if self.admission is not None:
            self._admit(now)
        want = ((self.sched.head_step >= BIG) | urgent_room(self)) & (self.sched.tail != self.goal)
        if want.any():
            self._plan(now)
        open_stalls(self, now)
        return dict(zip(self.names, zip(v.tolist(), w.tolist(), strict=True), strict=True))

    def _admit(self, now: float) -> None:
        """Admission: adapt the limit, start held goals within it (FIFO), and keep held robots idle where PIBT
        last pushed them (their goal is their cell: they never plan moves of their own, so they block nobody
        more than a robot at rest does, and PIBT pushes them like any robot without a goal)."""
        adm = self.admission
        assert adm is not None
        active = int(np.count_nonzero(self.pending))
        adm.update(now, active, int(np.count_nonzero(self.pending & (now - self.best_at >= self.stall_s))))
        adm.observe(self, now)
        for h in adm.admit(active, now):
            i = self._idx[h.robot]
            if self.parking is not None:
                self.parking.release(h.robot)
            self._set_goal(i, self._goal_node(h.robot, h.x, h.y))
            if not self.pending[i]:  # pushed onto its goal cell while held: already there
                self.stats["reached"] += 1
                if self.on_reached is not None:
                    self.on_reached(h.robot, now)
        for h in adm.queue:
            i = self._idx[h.robot]
            self.goal[i] = self._idle_goal(i, h.x, h.y)

    # ---- progress of one robot (O(changed); execution.py's arrivals call it) ------------------------------

    def _progress(self, i: int, now: float) -> None:
        name = self.names[i]
        d = float(self.grid.fields.to(int(self.goal[i]))[self.a[i]])
        if d < self.best[i] or d == 0:
            self.best[i], self.best_at[i] = d, now
            close_stall(self, i, now)
            if self.urgent_cells is not None and self.urgent_d[i] - d >= self.urgent_cells:
                self.urgent_at[i] = math.inf  # made its ground: urgent again after another urgent_s without progress
        if self.pending[i] and self.a[i] == self.goal[i]:  # there, even if the plan moves it on (pushed)
            self.pending[i] = False
            self.urgent_at[i] = math.inf
            self.stats["reached"] += 1
            if self.on_reached is not None:
                self.on_reached(name, now)

    def _plan(self, now: float) -> None:
        tail = self.sched.tail
        held = held_mask(self)  # once per plan, for the rules that treat held robots apart
        priority = priorities(self, now, held)
        if self.congestion is not None:
            self.congestion.refresh(now)
        frozen = np.flatnonzero(self.sched.queued >= lookahead(self)).tolist()
        self.pibt.box_for = bound_robots(self, now, held) if self.keep_clear else None  # no work when off
        self.pibt.keep_off, self.pibt.hot = held_off_ways(self, held) if self.held_clear else (None, set())
        self.pibt.hold_ground = holding_ground(self, now)  # None when off, or without aging to end a hold
        ahead = 2 * self.grid.xy[tail] - self.grid.xy[self.sched.before]  # straight on from the last move
        prefer = np.where(self.sched.before >= 0, self.grid.nodes_at(ahead), -1)
        nxt = np.asarray(self.pibt.step(tail.tolist(), self.goal.tolist(), priority, frozen, prefer.tolist()),
                         np.int64)
        self.sched.append(nxt)
        self.stats["steps"] += 1
        self.stats["pushes"] += len(self.pibt.pushes)

    def describe(self) -> dict[str, Any]:
        return {"robots": len(self.names), "cells": len(self.grid), "cell_m": self.grid.cell,
                "window": self.window, "priority": self.priority, "plan_step": self.sched.step,
                "fields_computed": self.grid.fields.computed,
                "congestion_fields": self.congestion.computed if self.congestion is not None else 0,
                "open_deadlocks": len(self.open_stalls),
                "longest_open_deadlock_s": max((self.service.world.time - t0 + self.stall_s
                                                for t0, _, _ in self.open_stalls.values()), default=0.0),
                "admission_limit": self.admission.limit if self.admission else math.inf,
                "held_now": len(self.admission.queue) if self.admission else 0,
                "urgent_now": int(np.isfinite(self.urgent_at).sum()),
                **(self.admission.stats if self.admission else {}), **self.stats}
