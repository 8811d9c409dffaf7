"""Deadlock detection and resolution: robots waiting on each other in a cycle, or stuck while commanded to move.

Each check (every `check_period_s` of sim time):
1. progress: a robot with an active navigation task that has not moved `progress_m` for `wait_s` is waiting;
2. wait-for graph: a waiting robot waits on each robot close ahead of it (towards its path);
3. a cycle in that graph (strongly connected component) is a deadlock; so is a robot waiting `stall_s`,
   together with the waiting robots within reach of it (a crowd jams without a strict cycle);
4. a `deadlock` event names the robots, and the policy resolves it: `priority` — the robot with the highest
   task priority (then the longest wait, then the name) waits while the others back off out of its way, then
   goes while they hold still (avoidance still on, so they make room); `replan` — each go-to robot plans
   again with the others' discs as temporary keep-outs; `none` — report only. A lone stalled robot backs
   off from what is around it and plans again.
The monitor is a ControlSource placed first in the control loop, so a back-off overrides the task's command.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from pydantic import Field
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

from fleet.avoidance.intent import lookahead_point
from fleet.swarm.unicycle import OFFSET  # the point ahead of the axle, as behaviours and ORCA use
from fleet.tasks.basic import GoToTask, NavTask
from sim.config import StrictModel

if TYPE_CHECKING:
    from fleet.fleet_view import FleetView

Command = tuple[float, float]
_ids = itertools.count(1)
CONTACT_GAP = 0.05  # m between footprint circles (whose boxes then nearly touch): back off straight


class DeadlockConfig(StrictModel):
    policy: Literal["priority", "replan", "none"] = "priority"
    check_period_s: float = Field(0.5, gt=0)
    progress_m: float = Field(0.25, gt=0, description="moving this far counts as progress, m")
    wait_s: float = Field(3.0, gt=0, description="no progress this long while commanded: the robot is waiting")
    stall_s: float = Field(10.0, gt=0, description="waiting this long is a deadlock even without a cycle")
    block_gap: float = Field(1.0, gt=0, description="a robot this close (edge to edge) ahead blocks, m")
    block_angle: float = Field(1.0, gt=0, le=3.2, description="'ahead' means within this of the path, rad")
    backoff_s: float = Field(4.0, ge=0, description="yielding robots move out of the way this long, s")
    backoff_speed: float = Field(0.3, gt=0, description="m/s")
    hold_s: float = Field(12.0, ge=0, description="then hold still (avoidance still makes room) until the winner "
                          "is `clear_distance` on or done, at most this long, s")
    clear_distance: float = Field(2.5, gt=0, description="m the winner must make before the others go on")
    resolve_timeout_s: float = Field(30.0, gt=0, description="a deadlock not cleared by then is unresolved, s")


@dataclass
class Deadlock:
    id: str
    kind: str  # cycle | stall
    robots: tuple[str, ...]
    detected: float
    policy: str
    winner: str | None = None
    state: str = "resolving"  # resolving | resolved | unresolved
    action: str = ""
    ended: float | None = None
    start_xy: dict[str, tuple[float, float]] = field(default_factory=dict)
    start_remaining: dict[str, float] = field(default_factory=dict)  # path length left at detection, m

    def to_dict(self) -> dict[str, Any]:
        return {"id": self.id, "kind": self.kind, "robots": list(self.robots), "detected": round(self.detected, 3),
                "policy": self.policy, "winner": self.winner, "action": self.action, "state": self.state,
                "ended": None if self.ended is None else round(self.ended, 3)}


@dataclass
class _Yield:
    deadlock: str
    winner: str
    until_backoff: float
    until_hold: float


def wait_for_cycles(edges: dict[str, set[str]]) -> list[tuple[str, ...]]:
    """The groups of robots that wait on each other in a cycle (strongly connected components of size ≥ 2)."""
    nodes = sorted(set(edges) | {j for js in edges.values() for j in js})
    if not nodes:
        return []
    idx = {n: i for i, n in enumerate(nodes)}
    rows = [idx[a] for a, js in edges.items() for _ in js]
    cols = [idx[b] for js in edges.values() for b in js]
    g = csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(nodes), len(nodes)))
    _, labels = connected_components(g, directed=True, connection="strong")
    groups = [tuple(nodes[i] for i in np.flatnonzero(labels == lab)) for lab in np.unique(labels)]
    return sorted(grp for grp in groups if len(grp) >= 2)


class DeadlockMonitor:
    """A ControlSource: detects deadlocks, publishes them, and drives yielding robots while they back off."""

    def __init__(self, view: FleetView, config: DeadlockConfig | None = None) -> None:
        self.view = view
        self.config = config or DeadlockConfig()
        self.deadlocks: dict[str, Deadlock] = {}
        self._anchor: dict[str, tuple[float, float, float]] = {}  # robot → (x, y, time of last progress)
        self._yield: dict[str, _Yield] = {}
        self._keepouts: dict[str, float] = {}  # robot → when to drop its temporary keep-outs (replan policy)
        self._next_check = 0.0

    # ---- ControlSource ---------------------------------------------------------------------------------

    def commands(self, now: float) -> dict[str, Command]:
        if now + 1e-9 >= self._next_check:
            self._next_check = now + self.config.check_period_s
            self._check(now)
        out: dict[str, Command] = {}
        for robot, y in list(self._yield.items()):
            if now >= y.until_hold or not self.view.robots.has(robot) or self._winner_clear(y, now):
                del self._yield[robot]
                self._anchor.pop(robot, None)  # a fresh start for its own progress clock
                continue
            backing = now < y.until_backoff and robot != y.winner
            out[robot] = self._backoff(robot, y.winner) if backing else (0.0, 0.0)
        return out

    def _winner_clear(self, y: _Yield, now: float) -> bool:
        """The winner is through: done, gone, or `clear_distance` from where it stood (after the back-off)."""
        if now < y.until_backoff:
            return False
        t, dl = self.view.robots, self.deadlocks[y.deadlock]
        if not t.has(y.winner) or not self._navigating(y.winner):
            return True
        i = t.index(y.winner)
        x0, y0 = dl.start_xy[y.winner]
        return bool(np.hypot(t.x[i] - x0, t.y[i] - y0) >= self.config.clear_distance)

    def owner(self, robot: str) -> str | None:
        y = self._yield.get(robot)
        return f"deadlock:{y.deadlock}" if y is not None else None

    def active_count(self) -> int:
        return len(self._yield)

    def cancel_all(self, reason: str) -> None:
        self._yield.clear()

    def release(self, robot: str, reason: str) -> None:
        self._yield.pop(robot, None)
        self._anchor.pop(robot, None)

    # ---- report ----------------------------------------------------------------------------------------

    def report(self) -> dict[str, Any]:
        ds = list(self.deadlocks.values())
        return {"detected": len(ds), "resolved": sum(d.state == "resolved" for d in ds),
                "unresolved": sum(d.state == "unresolved" for d in ds),
                "active": [d.to_dict() for d in ds if d.state == "resolving"],
                "recent": [d.to_dict() for d in ds[-20:]], "yielding": sorted(self._yield),
                "config": self.config.model_dump()}

    # ---- detection -------------------------------------------------------------------------------------

    def _check(self, now: float) -> None:
        cfg = self.config
        t = self.view.robots
        xy = t.xy
        waited: dict[str, float] = {}
        for i, name in enumerate(t.names):
            if not self._commanded(name):
                self._anchor.pop(name, None)
                continue
            ax, ay, at = self._anchor.get(name, (xy[i, 0], xy[i, 1], now))
            if np.hypot(xy[i, 0] - ax, xy[i, 1] - ay) >= cfg.progress_m:
                ax, ay, at = xy[i, 0], xy[i, 1], now
            self._anchor[name] = (ax, ay, at)
            if now - at >= cfg.wait_s:
                waited[name] = now - at
        self._drop_keepouts(now)
        self._update_open(now, xy, waited)
        busy = {r for d in self.deadlocks.values() if d.state == "resolving" for r in d.robots}
        edges = {a: self._blockers(a, xy) for a in waited if a not in busy}
        for group in wait_for_cycles(edges):
            if not busy.intersection(group):
                self._declare("cycle", group, now, xy, waited)
                busy.update(group)
        for a, w in sorted(waited.items()):
            if w >= cfg.stall_s and a not in busy:
                group = self._jam(a, waited, edges, xy, busy)
                self._declare("stall", group, now, xy, waited)
                busy.update(group)

    def _jam(self, robot: str, waited: dict[str, float], edges: dict[str, set[str]], xy: np.ndarray,
             busy: set[str]) -> tuple[str, ...]:
        """The robots stuck together with `robot`: the waiting robots within reach of each other (a crowd can
        block without a strict cycle: everyone held by neighbours beside it), plus whoever blocks them."""
        t = self.view.robots
        names = [n for n in waited if n not in busy]
        pts = xy[[t.index(n) for n in names]]
        reach = 2 * self.config.block_gap + 2 * float(t.radius.max())
        group, frontier = {robot}, [robot]
        while frontier:
            a = frontier.pop()
            d = np.hypot(*(pts - xy[t.index(a)]).T)
            for k in np.flatnonzero(d < reach):
                if names[k] not in group:
                    group.add(names[k])
                    frontier.append(names[k])
        blockers = {b for a in group for b in edges.get(a, set())} - busy
        return tuple(sorted(group | blockers))

    def _commanded(self, robot: str) -> bool:
        """Expected to make progress now: navigating, and neither yielding nor e-stopped."""
        return robot not in self._yield and not self.view.estopped(robot) and self._navigating(robot)

    def _navigating(self, robot: str) -> bool:
        task = self.view.active_task(robot)
        return isinstance(task, NavTask) and task.nav is not None and not task.nav.state.done

    def _direction(self, robot: str, i: int, xy: np.ndarray) -> np.ndarray:
        """Where the robot wants to go: towards a point ahead on its plan, else its heading."""
        task = self.view.active_task(robot)
        nav = task.nav if isinstance(task, NavTask) else None
        if nav is not None and nav.plans:
            target, _ = lookahead_point(nav.plans[-1].path, xy[i], 1.0)
            d = target - xy[i]
            if np.hypot(*d) > 1e-6:
                return np.asarray(d / np.hypot(*d))
        yaw = float(self.view.robots.yaw[i])
        return np.array([np.cos(yaw), np.sin(yaw)])

    def _blockers(self, robot: str, xy: np.ndarray) -> set[str]:
        t = self.view.robots
        i = t.index(robot)
        rel = xy - xy[i]
        gap = np.hypot(rel[:, 0], rel[:, 1]) - t.radius - t.radius[i]
        d = self._direction(robot, i, xy)
        cos = (rel @ d) / np.maximum(np.hypot(rel[:, 0], rel[:, 1]), 1e-9)
        near = (gap < self.config.block_gap) & (cos > np.cos(self.config.block_angle))
        near[i] = False
        return {t.names[j] for j in np.flatnonzero(near)}

    # ---- resolution ------------------------------------------------------------------------------------

    def _declare(self, kind: str, group: tuple[str, ...], now: float, xy: np.ndarray,
                 waited: dict[str, float]) -> None:
        view, cfg = self.view, self.config
        t = view.robots
        dl = Deadlock(f"d{next(_ids)}", kind, tuple(group), now, cfg.policy,
                      start_xy={r: (float(xy[t.index(r), 0]), float(xy[t.index(r), 1])) for r in group})
        dl.start_remaining = {r: self._remaining(r) for r in group}
        self.deadlocks[dl.id] = dl
        for r in group:  # progress is measured afresh from here
            self._anchor.pop(r, None)
        action = "reported only"
        if cfg.policy != "none" and len(group) == 1:  # nobody to negotiate with: step clear, plan again
            self._yield[group[0]] = _Yield(dl.id, "", now + cfg.backoff_s, now + cfg.backoff_s)
            action = "backing off and replanning" if self._replan(dl, now) else "backing off"
        elif cfg.policy == "priority" or (cfg.policy == "replan" and not self._replan(dl, now)):
            dl.winner = max(group, key=lambda r: (self._priority(r), waited.get(r, 0.0), [-ord(c) for c in r]))
            for r in group:  # the winner waits while the others back off, then goes while they hold still
                hold = 0.0 if r == dl.winner else cfg.hold_s
                self._yield[r] = _Yield(dl.id, dl.winner, now + cfg.backoff_s, now + cfg.backoff_s + hold)
            action = f"{dl.winner} goes first; {', '.join(r for r in group if r != dl.winner)} back off and yield"
        elif cfg.policy == "replan":
            action = "replanning around each other"
        dl.action = action
        view.publish(now, "deadlock", group, f"deadlock ({kind}) between {', '.join(group)}: {action}",
                     id=dl.id, type=kind, policy=cfg.policy, winner=dl.winner)

    def _progressed(self, dl: Deadlock, robot: str, xy: np.ndarray) -> bool:
        """Gone, done, or closer to its goal along its path by 2 × progress_m than at detection (backing off
        does not count)."""
        t = self.view.robots
        if not t.has(robot) or not self._commanded(robot):
            return True
        before, now = dl.start_remaining[robot], self._remaining(robot)
        if math.isfinite(before) and math.isfinite(now):
            return now <= before - 2 * self.config.progress_m
        return bool(np.hypot(*(xy[t.index(robot)] - dl.start_xy[robot])) >= 2 * self.config.progress_m)

    def _remaining(self, robot: str) -> float:
        """Path length the robot's navigator has left (inf when it has none): progress means this shrinks."""
        task = self.view.active_task(robot)
        left = task.progress.get("distance_remaining") if task is not None else None
        return float(left) if isinstance(left, int | float) and math.isfinite(left) else math.inf

    def _priority(self, robot: str) -> float:
        task = self.view.active_task(robot)
        return float(task.priority) if task is not None else -np.inf  # an idle robot always yields

    def _backoff(self, robot: str, winner: str) -> Command:
        """Move away from the robots around (the closest most), sideways out of the winner's lane and away from
        walls, as (v, ω) through the point ahead of the axle."""
        view = self.view
        t = view.robots
        i = t.index(robot)
        xy = t.xy
        rel = xy[i] - xy
        d2 = np.maximum((rel**2).sum(axis=1), 1e-6)
        near = (d2 < 4.0) & (np.arange(len(xy)) != i)
        e = (rel[near] / d2[near, None]).sum(axis=0)  # away from everyone close, the closest most
        e /= max(float(np.hypot(*e)), 1e-6)
        if t.has(winner):
            k = t.index(winner)
            lane = self._direction(winner, k, xy)
            side = np.array([lane[1], -lane[0]])  # out of the winner's lane, on the side we are already on
            e = e + (side if side @ (xy[i] - xy[k]) >= 0 else -side)
        dist, normal = view.static_clearance().query(xy[i:i + 1])
        if dist[0] < 0.8:
            e -= normal[0] * 2.0 * (1.0 - dist[0] / 0.8)
        wall_gap = float(dist[0] - t.radius[i])
        n = float(np.hypot(*e))
        if n < 1e-6:
            return (0.0, 0.0)
        u = e / n * self.config.backoff_speed
        yaw = float(t.yaw[i])
        h, hp = np.array([np.cos(yaw), np.sin(yaw)]), np.array([-np.sin(yaw), np.cos(yaw)])
        gap = np.sqrt(d2[near]) - t.radius[near] - t.radius[i] if near.any() else np.array([np.inf])
        if gap.min() < CONTACT_GAP or wall_gap < 2 * CONTACT_GAP:  # touching: a turn would swing a corner
            facing = float(normal[0] @ h)  # into it; straight out first (away from the wall when at one)
            sign = -np.sign(facing) if wall_gap < 2 * CONTACT_GAP and abs(facing) > 0.2 else np.sign(u @ h)
            return float(sign or -1.0) * self.config.backoff_speed, 0.0
        return float(u @ h), float(np.clip((u @ hp) / OFFSET, -t.max_w[i], t.max_w[i]))

    def _replan(self, dl: Deadlock, now: float) -> bool:
        """Each go-to robot of the group plans again with the others as temporary keep-outs."""
        view = self.view
        t = view.robots
        tasks = {r: view.active_task(r) for r in dl.robots}
        if not all(isinstance(task, GoToTask) and task.nav is not None for task in tasks.values()):
            return False
        for r, task in tasks.items():
            assert isinstance(task, GoToTask) and task.nav is not None
            cm = view.costmap(r)
            for o in dl.robots:
                if o != r:
                    j = t.index(o)
                    cm.add_keepout(_disc(float(t.x[j]), float(t.y[j]), float(t.radius[j]) + 0.1))
            goal = task.nav.status().goal
            assert goal is not None
            task.nav.set_goal(goal, now, align_yaw=bool(task.params.get("align_yaw", False)))
            if len(dl.robots) > 1:
                self._keepouts[r] = now + self.config.check_period_s
        return True

    def _drop_keepouts(self, now: float) -> None:
        for r, until in list(self._keepouts.items()):
            if now >= until:
                del self._keepouts[r]
                if self.view.robots.has(r):
                    cm = self.view.costmap(r)
                    cm.clear_keepouts()
                    for poly in self.view.keepouts():
                        cm.add_keepout(poly)

    def _update_open(self, now: float, xy: np.ndarray, waited: dict[str, float]) -> None:
        """A deadlock is resolved once each of its robots moved on (or no longer needs to move); it is unresolved
        when, released, its robots are stuck again (or it times out): they may then be detected afresh."""
        for dl in self.deadlocks.values():
            if dl.state != "resolving" or any(r in self._yield for r in dl.robots):
                continue
            moved = all(self._progressed(dl, r, xy) for r in dl.robots)
            acted = dl.policy != "none"  # a report-only deadlock stays open until it clears or times out
            stuck = acted and any(r in waited for r in dl.robots) and now - dl.detected > self.config.wait_s
            if moved or stuck or now - dl.detected > self.config.resolve_timeout_s:
                dl.state, dl.ended = ("resolved" if moved else "unresolved"), now
                kind = "deadlock_resolved" if moved else "deadlock_unresolved"
                self.view.publish(now, kind, dl.robots, f"deadlock {dl.id} {dl.state} after "
                                  f"{now - dl.detected:.1f} s", id=dl.id)




def _disc(x: float, y: float, r: float, n: int = 12) -> list[tuple[float, float]]:
    a = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return [(x + r * float(np.cos(t)), y + r * float(np.sin(t))) for t in a]
