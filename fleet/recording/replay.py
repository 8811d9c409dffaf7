"""Replay: re-drive a fresh world from a recording and measure how far it strays from the recorded poses.

The recording holds the mission actually run (world, physics, seed), every robot's spawn pose, and after
each control tick the command in force and the e-stop state of every robot. Replay builds the same world,
spawns the robots where they were, re-applies the scripted events that change the world (obstacles, sensor
faults, removals) and feeds each tick's commands straight to the world — no planners, no tasks. In a
deterministic run the replayed poses match the recorded ones; a divergence means the world itself changed
(physics, drive model, a world file) since the recording was made.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from fleet.missions.events import RemoveObstacle, SensorFault, SpawnObstacle, obstacle_pose, obstacle_sdf
from fleet.missions.loader import mission_from_text
from fleet.paths import robot_model
from fleet.recording.reader import metadata, states
from fleet.recording.types import MISSION_METADATA, SPAWN_METADATA, ReplayResult
from sim import Pose2D, World
from sim.errors import ErrorCode, FleetError


def replay(path: str | Path) -> ReplayResult:
    meta = metadata(path)
    if MISSION_METADATA not in meta or SPAWN_METADATA not in meta:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{path} is not a fleetnav mission recording",
                         f"it lacks the {MISSION_METADATA} / {SPAWN_METADATA} metadata records")
    mission = mission_from_text(meta[MISSION_METADATA]["yaml"], f"{path}#{MISSION_METADATA}")
    seed = int(meta[MISSION_METADATA]["seed"])
    spawn = json.loads(meta[SPAWN_METADATA]["robots"])
    ph = mission.physics
    world = World.from_sdf(mission.world, physics_hz=ph.physics_hz, seed=seed, fidelity=ph.fidelity)
    try:
        for name, r in spawn.items():
            world.spawn_robot(name, Pose2D(*r["pose"]), spec=robot_model(r["model"]).spec,
                              fidelity=r["fidelity"])
        return _drive(world, mission.events, round(ph.physics_hz / ph.control_hz), str(path), list(spawn))
    finally:
        world.close()


def _drive(world: World, events: list, steps: int, source: str, robots: list[str]) -> ReplayResult:
    pending = sorted((e for e in events if isinstance(e, SpawnObstacle | RemoveObstacle | SensorFault)
                      or (e.type == "kill_robot" and e.mode == "remove")), key=lambda e: e.at)
    worst: dict[str, float] = dict.fromkeys(robots, 0.0)
    final: dict[str, float] = {}
    ticks = 0
    for st in states(source):
        while pending and pending[0].at <= world.time + 1e-9:
            _apply(world, pending.pop(0))
        for name, (v, w), stopped in zip(st["names"], st["cmd"], st["estopped"], strict=True):
            if stopped:
                world.emergency_stop(name)
            else:
                world.set_cmd_vel(name, v, w)
        world.step(steps)
        ticks += 1
        for name, (x, y, _) in zip(st["names"], st["pose"], strict=True):
            p = world.robot_pose(name)
            final[name] = math.hypot(p.x - x, p.y - y)
            worst[name] = max(worst.get(name, 0.0), final[name])
    return ReplayResult(source, ticks, round(world.time, 6), robots, worst, final)


def _apply(world: World, e: object) -> None:
    if isinstance(e, SpawnObstacle):
        world.spawn_model(xml=obstacle_sdf(e), pose=obstacle_pose(e), static=True)
    elif isinstance(e, RemoveObstacle):
        world.remove_model(e.name)
    elif isinstance(e, SensorFault):
        world.set_sensor_fault(e.robot, e.sensor, dropout=e.dropout, noise_scale=e.noise_scale)
    else:
        world.remove_robot(getattr(e, "robot", ""))
