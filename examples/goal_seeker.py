"""A goal-seeking, obstacle-avoiding controller over the Zenoh API, runnable as its own process.

    python examples/goal_seeker.py --connect tcp/127.0.0.1:7447 --robot r1 --goal 5 5

Once, it asks the world for its occupancy map over the Zenoh API and plans a route (Theta* on a costmap
inflated by the robot's radius) so it can get out of mazes; `--no-plan` seeks the goal directly. Each control
step it picks, among the lidar beams with enough clearance for the robot's width, the heading closest to the
bearing of a carrot point a little way along the route (a one-step vector field histogram), turns toward it
and slows down as the way ahead closes in. It paces itself on sim time (a new pose message), so it runs at
any sim speed; with --lockstep the world waits for it every control tick instead.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from fleet.agent import Agent
from fleet.zenoh_api import PoseStamped, Scan
from sim.errors import FleetError


@dataclass(frozen=True)
class SeekerParams:
    max_v: float = 0.6  # m/s
    max_w: float = 1.5  # rad/s
    tolerance: float = 0.25  # m: goal reached
    robot_radius: float = 0.35  # m, footprint plus margin
    lookahead: float = 1.2  # m: a beam this clear (or clear to the goal) is open
    k_turn: float = 2.0


def command(pose: PoseStamped, scan: Scan | None, goal: tuple[float, float],
            p: SeekerParams = SeekerParams()) -> tuple[float, float, bool]:
    """(v, w, reached) for one step; a pure function of the latest pose and scan."""
    dx, dy = goal[0] - pose.x, goal[1] - pose.y
    dist = math.hypot(dx, dy)
    if dist < p.tolerance:
        return 0.0, 0.0, True
    bearing = _wrap(math.atan2(dy, dx) - pose.yaw)
    heading, front = bearing, math.inf
    if scan is not None:
        ranges = np.where(np.isfinite(scan.ranges), scan.ranges, scan.range_max)
        angles = scan.angles()
        # a heading is open if no return comes closer than the robot's half-width to the corridor along it
        need = min(dist, p.lookahead)
        half = np.arcsin(np.clip(p.robot_radius / np.maximum(ranges, p.robot_radius), 0, 1))
        blocked = np.zeros(ranges.size, dtype=bool)
        for i in np.flatnonzero(ranges < need + p.robot_radius):  # widen each near return by its angular size
            blocked |= np.abs(_wrap_arr(angles - angles[i])) <= half[i]
        open_idx = np.flatnonzero(~blocked)
        if open_idx.size == 0:
            return 0.0, p.max_w, False  # boxed in: turn on the spot
        heading = float(angles[open_idx[np.argmin(np.abs(_wrap_arr(angles[open_idx] - bearing)))]])
        ahead = np.abs(angles) < math.radians(20)
        front = float(ranges[ahead].min())
    w = float(np.clip(p.k_turn * heading, -p.max_w, p.max_w))
    slow = min(1.0, dist / 1.0, max(0.0, (front - p.robot_radius) / p.lookahead))
    v = p.max_v * slow * max(0.0, math.cos(heading))
    return v, w, False


class Route:
    """The planned polyline and a carrot point `lookahead` metres past the robot's projection onto it."""

    def __init__(self, path: np.ndarray, lookahead: float = 1.0) -> None:
        self.path = np.asarray(path, dtype=float)
        seg = np.diff(self.path, axis=0)
        self.cum = np.concatenate([[0.0], np.cumsum(np.hypot(seg[:, 0], seg[:, 1]))])
        self.lookahead = lookahead
        self.progress = 0.0

    def carrot(self, x: float, y: float) -> tuple[float, float]:
        # project onto the route near where we were (never backwards), then look ahead along it
        a, b = self.path[:-1], self.path[1:]
        d = b - a
        t = np.clip(((x - a[:, 0]) * d[:, 0] + (y - a[:, 1]) * d[:, 1]) / np.maximum((d**2).sum(1), 1e-12), 0, 1)
        proj = a + t[:, None] * d
        dist = np.hypot(proj[:, 0] - x, proj[:, 1] - y)
        s = self.cum[:-1] + t * (self.cum[1:] - self.cum[:-1])
        ok = s >= self.progress - 0.5
        k = int(np.argmin(np.where(ok, dist, np.inf)))
        self.progress = max(self.progress, float(s[k]))
        target = min(self.progress + self.lookahead, float(self.cum[-1]))
        j = int(np.clip(np.searchsorted(self.cum, target) - 1, 0, len(self.path) - 2))
        f = (target - self.cum[j]) / max(self.cum[j + 1] - self.cum[j], 1e-12)
        px, py = self.path[j] + f * (self.path[j + 1] - self.path[j])
        return float(px), float(py)


def plan_route(agent: Agent, start: tuple[float, float], goal: tuple[float, float],
               radius: float) -> Route | None:
    """A route over the world's occupancy map (None if the map is unavailable or no route exists)."""
    from planning import LayeredCostmap, OccupancyGrid, get_planner
    from sim.errors import FleetError
    from sim.types import Pose2D

    try:
        data, res, origin = agent.occupancy_map()
        costmap = LayeredCostmap(OccupancyGrid(data, res, origin), robot_radius=radius)
        plan = get_planner("guided_theta_star").plan(Pose2D(*start, 0.0), Pose2D(*goal, 0.0), costmap)
    except FleetError as exc:
        print(f"goal_seeker: no route ({exc.message}); seeking the goal directly", file=sys.stderr)
        return None
    return Route(plan.path)


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def _wrap_arr(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


def run(connect: str, robot: str, goal: tuple[float, float], *, agent_id: str = "goal_seeker",
        world: str | None = None, lockstep: bool = False, timeout: float = 120.0, delay: float = 0.0,
        params: SeekerParams = SeekerParams(), plan: bool = True) -> dict[str, Any]:
    """Drive `robot` to `goal` (map frame); returns where it ended and whether it arrived."""
    with Agent(agent_id, connect=connect, world=world) as agent:
        link = agent.robot(robot, streams=("pose", "scan"))
        start = link.wait("pose", timeout=timeout)
        route = plan_route(agent, (start.x, start.y), goal, params.robot_radius) if plan else None
        reached = False
        ticks: list[int] = []

        def step(tick: int, stamp: float) -> dict[str, tuple[float, float]] | None:
            nonlocal reached
            ticks.append(tick)
            if delay:
                time.sleep(delay)  # --delay: stands in for a slow controller's computation
            pose = link.pose or link.wait("pose")
            near_goal = math.hypot(goal[0] - pose.x, goal[1] - pose.y) < 1.0
            target = goal if route is None or near_goal else route.carrot(pose.x, pose.y)
            v, w, _ = command(pose, link.scan, target, params)
            reached = math.hypot(goal[0] - pose.x, goal[1] - pose.y) < params.tolerance
            return None if reached else {robot: (v, w)}

        if lockstep:
            agent.lockstep([robot], step, tick_timeout=timeout)
        else:
            deadline, stamp = time.monotonic() + timeout, -math.inf
            while not reached and time.monotonic() < deadline:
                pose = link.wait("pose", timeout=timeout, newer_than=stamp)  # pace on sim time, not wall time
                stamp = pose.stamp
                cmds = step(0, stamp)
                if cmds is not None:
                    link.drive(*cmds[robot])
        link.stop()
        final = link.pose
        assert final is not None
        return {"robot": robot, "reached": reached, "x": final.x, "y": final.y, "sim_time": agent.sim_time,
                "ticks": ticks if lockstep else len(ticks), "errors": list(agent.errors)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--connect", default="tcp/127.0.0.1:7447", help="the world's Zenoh endpoint (default: "
                    "`fleetnav zenoh` on this machine)")
    ap.add_argument("--robot", required=True)
    ap.add_argument("--goal", nargs=2, type=float, default=(5.0, 5.0), metavar=("X", "Y"))
    ap.add_argument("--agent-id", default="goal_seeker")
    ap.add_argument("--world", default=None, help="world key, if several worlds share the network")
    ap.add_argument("--lockstep", action="store_true", help="the world waits for this agent every tick")
    ap.add_argument("--timeout", type=float, default=120.0, help="wall seconds")
    ap.add_argument("--delay", type=float, default=0.0, help="seconds of simulated computation per step")
    ap.add_argument("--no-plan", action="store_true", help="seek the goal directly (no map, no route)")
    a = ap.parse_args(argv)
    try:
        result = run(a.connect, a.robot, (a.goal[0], a.goal[1]), agent_id=a.agent_id, world=a.world,
                     lockstep=a.lockstep, timeout=a.timeout, delay=a.delay, plan=not a.no_plan)
    except FleetError as exc:  # unknown robot, no world, ...: one clear line, not a traceback
        print(f"error: {exc}", file=sys.stderr, flush=True)
        return 2
    print(json.dumps(result), flush=True)
    return 0 if result["reached"] else 1


if __name__ == "__main__":
    sys.exit(main())
