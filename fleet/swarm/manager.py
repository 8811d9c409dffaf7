"""The behaviour manager: runs swarm behaviours as a ControlSource of the control loop.

Each control tick, for every running behaviour: read its robots' state from the world table, ask it for
desired planar velocities, add a push away from static obstacles and the geofence, saturate, map to (v, ω)
through the point ahead of the axle, and record the behaviour's outcome metrics (history once per second,
the first time it converged).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from fleet.swarm.coverage import LloydCoverage
from fleet.swarm.registry import behaviour_config, make_behaviour, min_robots
from fleet.swarm.types import Behaviour, SwarmState
from fleet.swarm.unicycle import OFFSET, saturate, to_unicycle
from sim.errors import ErrorCode, FleetError

if TYPE_CHECKING:
    from fleet.fleet_view import FleetView

Command = tuple[float, float]
_ids = itertools.count(1)
WALL_DISTANCE = 0.6  # m: behaviours are pushed away from static obstacles and the geofence inside this
HISTORY = 600


@dataclass
class RunningBehaviour:
    id: str
    type: str
    robots: list[str]
    params: dict[str, Any]
    behaviour: Behaviour
    started: float
    state: str = "running"  # running | stopped
    reason: str = ""
    ended: float | None = None
    converged_at: float | None = None
    metrics: dict[str, float] = field(default_factory=dict)
    initial: dict[str, float] = field(default_factory=dict)
    history: list[dict[str, float]] = field(default_factory=list)

    def to_dict(self, with_history: bool = False) -> dict[str, Any]:
        d: dict[str, Any] = {
            "id": self.id, "type": self.type, "robots": list(self.robots), "state": self.state,
            "reason": self.reason, "started": round(self.started, 3),
            "ended": None if self.ended is None else round(self.ended, 3),
            "metrics": _round(self.metrics), "initial_metrics": _round(self.initial),
            "converged": self.converged_at is not None,
            "convergence_time_s": None if self.converged_at is None else round(self.converged_at - self.started, 3)}
        if with_history:
            d["history"] = [_round(h) for h in self.history]
        return d


def _round(m: dict[str, float]) -> dict[str, float | None]:
    return {k: (round(v, 4) if math.isfinite(v) else None) for k, v in m.items()}


class BehaviourManager:
    def __init__(self, view: FleetView) -> None:
        self.view = view
        self.running: dict[str, RunningBehaviour] = {}  # every behaviour started (stopped ones kept for status)
        self._owner: dict[str, str] = {}  # robot → id of the running behaviour that drives it

    # ---- control ---------------------------------------------------------------------------------------

    def start(self, type_name: str, robots: list[str], params: dict[str, Any] | None = None) -> RunningBehaviour:
        """Validate, take the robots over from whatever drives them, and start (on the sim thread)."""
        view = self.view
        spec = {**(params or {}), "type": type_name}
        behaviour_config(spec)  # unknown type / bad parameter → clear error before anything changes
        if len(set(robots)) != len(robots):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, "a robot is listed twice", f"robots: {', '.join(robots)}")
        for r in robots:
            view.robot_record(r)
        need = min_robots(type_name)
        if len(robots) < need:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"behaviour '{type_name}' needs at least {need} robots, "
                             f"got {len(robots)}")
        beh = make_behaviour(spec)
        state = self.state(robots)
        if isinstance(beh, LloydCoverage):  # only open floor counts as area to cover
            beh.restrict(view.static_clearance().query(beh.points)[0] > 0.0)
        beh.start(state)
        for r in robots:
            view.release(r, f"taken over by behaviour {type_name}")
        run = RunningBehaviour(f"b{next(_ids)}", type_name, list(robots), dict(params or {}), beh, view.time)
        run.metrics = run.initial = beh.metrics(state)
        run.history.append({"t": 0.0, **run.metrics})
        self.running[run.id] = run
        self._owner.update({r: run.id for r in robots})
        view.publish(view.time, "behaviour_started", robots, f"{type_name} {run.id} started",
                     id=run.id, type=type_name)
        return run

    def stop(self, behaviour_id: str, reason: str = "stopped by request") -> RunningBehaviour:
        run = self.get(behaviour_id)
        if run.state == "running":
            run.state, run.reason, run.ended = "stopped", reason, self.view.time
            for r in run.robots:
                if self._owner.get(r) == run.id:
                    del self._owner[r]
            self.view.publish(run.ended, "behaviour_stopped", run.robots,
                              f"{run.type} {run.id} stopped: {reason}", id=run.id, metrics=run.metrics)
        return run

    def get(self, behaviour_id: str) -> RunningBehaviour:
        if behaviour_id not in self.running:
            raise FleetError(ErrorCode.NOT_FOUND, f"no behaviour '{behaviour_id}'",
                             f"behaviours: {', '.join(self.running) or 'none'}")
        return self.running[behaviour_id]

    def state(self, robots: list[str]) -> SwarmState:
        view = self.view
        t = view.robots
        idx = np.array([t.index(r) for r in robots], dtype=np.int64)
        centre, yaw = np.column_stack([t.x[idx], t.y[idx]]), t.yaw[idx]
        point = centre + OFFSET * np.column_stack([np.cos(yaw), np.sin(yaw)])
        return SwarmState(tuple(robots), view.time, view.control_dt, point, centre, yaw,
                          t.v[idx], t.w[idx], t.radius[idx], t.max_v[idx], OFFSET)

    # ---- ControlSource ---------------------------------------------------------------------------------

    def commands(self, now: float) -> dict[str, Command]:
        out: dict[str, Command] = {}
        for run in self.running.values():
            if run.state == "running":
                out.update(self._tick(run, now))
        return out

    def owner(self, robot: str) -> str | None:
        bid = self._owner.get(robot)
        return f"behaviour:{bid}" if bid is not None else None

    def active_count(self) -> int:
        return len(self._owner)

    def avoidance_group(self, robot: str) -> int:
        """≥ 0 (one number per behaviour) when the robot's behaviour keeps its robots apart by itself, else -1."""
        bid = self._owner.get(robot)
        if bid is None or not getattr(self.running[bid].behaviour, "separates_itself", False):
            return -1
        return int(bid[1:])

    def cancel_all(self, reason: str) -> None:
        for bid, run in self.running.items():
            if run.state == "running":
                self.stop(bid, reason)

    def release(self, robot: str, reason: str) -> None:
        """The robot leaves its behaviour; a behaviour left with too few robots stops."""
        bid = self._owner.pop(robot, None)
        if bid is None:
            return
        run = self.running[bid]
        run.robots.remove(robot)
        if len(run.robots) < max(1, min_robots(run.type)):
            self.stop(bid, f"{robot} left ({reason}); too few robots")
            return
        run.behaviour.start(self.state(run.robots))  # re-assign slots among those left

    # ---- one behaviour, one tick -------------------------------------------------------------------------

    def _tick(self, run: RunningBehaviour, now: float) -> dict[str, Command]:
        view = self.view
        state = self.state(run.robots)
        u = np.asarray(run.behaviour.velocities(state), dtype=float)
        driven = ~np.isnan(u).any(axis=1)
        u = saturate(np.nan_to_num(u) + self._keep_off_walls(state), state.max_v)
        t = view.robots
        idx = [t.index(r) for r in run.robots]
        cmd = to_unicycle(u, state.yaw, state.max_v, t.max_w[idx])
        run.metrics = run.behaviour.metrics(state)
        if run.converged_at is None and run.behaviour.converged(state, run.metrics):
            run.converged_at = now
            view.publish(now, "behaviour_converged", run.robots, f"{run.type} {run.id} converged after "
                         f"{now - run.started:.1f} s", id=run.id, metrics=run.metrics)
        if now - run.started - (run.history[-1]["t"] if run.history else 0.0) >= 1.0 - 1e-9:
            run.history.append({"t": now - run.started, **run.metrics})
            del run.history[:-HISTORY]
        return {r: (float(cmd[k, 0]), float(cmd[k, 1])) for k, r in enumerate(run.robots) if driven[k]}

    def _keep_off_walls(self, state: SwarmState) -> np.ndarray:
        """A push away from static obstacles and the geofence, growing inside WALL_DISTANCE (m/s)."""
        view = self.view
        dist, normal = view.static_clearance().query(state.centre)
        gap = np.maximum(dist - state.radius, 0.0)
        push = -normal * (state.max_v * np.clip(1.0 - gap / WALL_DISTANCE, 0.0, 1.0))[:, None]
        xmin, ymin, xmax, ymax = view.fence
        lo = np.array([xmin, ymin]) + state.radius[:, None] + WALL_DISTANCE
        hi = np.array([xmax, ymax]) - state.radius[:, None] - WALL_DISTANCE
        inward = np.clip(lo - state.centre, 0.0, None) - np.clip(state.centre - hi, 0.0, None)
        return np.asarray(push + inward * state.max_v[:, None] / WALL_DISTANCE)
