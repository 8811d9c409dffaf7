"""A wall follower over the Zenoh API, runnable as its own process.

    python examples/wall_follower.py --connect tcp/127.0.0.1:7447 --robot r1 --duration 30

It keeps the nearest wall on one side at a set distance using only the lidar: a proportional term on the
distance error plus one on the wall's angle (from the beams at 60° and 90° to that side), and it turns away
when something closes in ahead. It paces on sim time (each new scan); with --lockstep the world waits for it.
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
from fleet.zenoh_api import Scan
from sim.errors import FleetError


@dataclass(frozen=True)
class FollowParams:
    side: str = "right"  # wall on this side
    distance: float = 0.8  # m to keep from the wall
    speed: float = 0.4  # m/s
    k_dist: float = 1.5
    k_angle: float = 1.5
    max_w: float = 1.2


def _range_at(scan: Scan, angle: float, width: float = math.radians(5)) -> float:
    """Nearest return within ±width of `angle` (lidar frame), range_max when nothing answers."""
    d = np.abs((scan.angles() - angle + np.pi) % (2 * np.pi) - np.pi)
    r = scan.ranges[d <= width]
    r = r[np.isfinite(r)]
    return float(r.min()) if r.size else scan.range_max


def command(scan: Scan, p: FollowParams = FollowParams()) -> tuple[float, float]:
    s = -1.0 if p.side == "right" else 1.0  # angles toward the wall side
    side = _range_at(scan, s * math.pi / 2)
    diag = _range_at(scan, s * math.pi / 3)
    front = _range_at(scan, 0.0, math.radians(20))
    if front < p.distance + 0.2:  # a wall ahead: turn away from the followed side on the spot-ish
        return 0.05, -s * p.max_w
    if side > 3 * p.distance and diag > 3 * p.distance:  # lost the wall: arc toward its side to find it
        return p.speed, s * 0.5
    # the robot's angle to the wall from two beams 30° apart: 0 when parallel, negative when heading into it
    alpha = math.atan2(diag * math.cos(math.pi / 6) - side, diag * math.sin(math.pi / 6))
    dist = side * math.cos(alpha)
    w = -s * (p.k_dist * (p.distance - dist) - p.k_angle * alpha)
    return p.speed * max(0.2, min(1.0, (front - p.distance) / p.distance)), float(np.clip(w, -p.max_w, p.max_w))


def run(connect: str, robot: str, *, duration: float = 30.0, agent_id: str = "wall_follower",
        world: str | None = None, lockstep: bool = False, timeout: float = 120.0, delay: float = 0.0,
        params: FollowParams = FollowParams()) -> dict[str, Any]:
    """Follow a wall for `duration` sim seconds; returns the closest the lidar got to anything and the ticks."""
    with Agent(agent_id, connect=connect, world=world) as agent:
        link = agent.robot(robot, streams=("scan", "pose"))
        end = math.inf
        closest = math.inf
        ticks: list[int] = []

        def step(tick: int, stamp: float) -> dict[str, tuple[float, float]] | None:
            nonlocal closest, end
            end = min(end, stamp + duration)  # the first step starts the clock
            if stamp >= end:
                return None
            ticks.append(tick)
            if delay:
                time.sleep(delay)  # --delay: stands in for a slow controller's computation
            scan = link.scan
            if scan is None:  # (lock-step from t = 0: the first scan comes with the first lidar period)
                return {robot: (0.0, 0.0)}
            finite = scan.ranges[np.isfinite(scan.ranges)]
            closest = min(closest, float(finite.min())) if finite.size else closest
            return {robot: command(scan, params)}

        if lockstep:
            agent.lockstep([robot], step, tick_timeout=timeout)
        else:
            deadline, stamp = time.monotonic() + timeout, -math.inf
            while time.monotonic() < deadline:
                scan = link.wait("scan", timeout=timeout, newer_than=stamp)
                stamp = scan.stamp
                cmds = step(0, stamp)
                if cmds is None:
                    break
                link.drive(*cmds[robot])
        link.stop()
        pose = link.pose
        return {"robot": robot, "closest": closest, "sim_time": agent.sim_time,
                "ticks": ticks if lockstep else len(ticks), "x": pose.x if pose else None,
                "y": pose.y if pose else None, "errors": list(agent.errors)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--connect", default="tcp/127.0.0.1:7447", help="the world's Zenoh endpoint (default: "
                    "`fleetnav zenoh` on this machine)")
    ap.add_argument("--robot", required=True)
    ap.add_argument("--duration", type=float, default=30.0, help="sim seconds to follow the wall")
    ap.add_argument("--side", choices=("left", "right"), default="right")
    ap.add_argument("--distance", type=float, default=0.8)
    ap.add_argument("--agent-id", default="wall_follower")
    ap.add_argument("--world", default=None)
    ap.add_argument("--lockstep", action="store_true", help="the world waits for this agent every tick")
    ap.add_argument("--timeout", type=float, default=120.0, help="wall seconds")
    ap.add_argument("--delay", type=float, default=0.0, help="seconds of simulated computation per step")
    a = ap.parse_args(argv)
    try:
        result = run(a.connect, a.robot, duration=a.duration, agent_id=a.agent_id, world=a.world,
                     lockstep=a.lockstep, timeout=a.timeout, delay=a.delay,
                     params=FollowParams(side=a.side, distance=a.distance))
    except FleetError as exc:  # unknown robot, no world, ...: one clear line, not a traceback
        print(f"error: {exc}", file=sys.stderr, flush=True)
        return 2
    print(json.dumps(result), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
