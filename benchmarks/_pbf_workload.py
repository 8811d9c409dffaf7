"""The peer's side of the fleet benchmark: pybullet-fleet 0.8.0 running the same scene as sim_throughput.py.

Runs in the throwaway venv (/tmp/pbf/bin/python), never in ours: it imports only pybullet_fleet, numpy and
the standard library. Usage: `/tmp/pbf/bin/python benchmarks/_pbf_workload.py scene.json`; prints one JSON
line with the measured figures.

What it does (the peer's own recommended fleet setup, see its examples/scale/batch_controller_scale_demo.py):
MultiRobotSimulationCore(physics=False, timestep=0.1, target_rtf=0), a constant 2 m spatial-hash cell,
one AgentManager with the vectorised `batch_differential` controller, every robot following a path of
random waypoints (rotate, then drive) with our robot's limits, static obstacles registered as STATIC
collision objects, and collision *detection* every step (getClosestPoints on AABB-overlapping pairs,
robots against robots and obstacles). Collisions are reported, not resolved: robots pass through.
"""

from __future__ import annotations

import json
import math
import sys
import time
from importlib import metadata
from typing import Any

import numpy as np
from pybullet_fleet import AgentSpawnParams, MultiRobotSimulationCore, Pose, SimulationParams
from pybullet_fleet.agent_manager import AgentManager
from pybullet_fleet.sim_object import ShapeParams, SimObject, SimObjectSpawnParams
from pybullet_fleet.types import CollisionMode, SpatialHashCellSizeMode

WAYPOINTS = 40  # enough random legs that no robot finishes its path during the run


def make_sim(ignore_static: bool) -> MultiRobotSimulationCore:
    return MultiRobotSimulationCore(SimulationParams(
        target_rtf=0, gui=False, monitor=False, enable_monitor_gui=False, physics=False, timestep=0.1,
        spatial_hash_cell_size_mode=SpatialHashCellSizeMode.CONSTANT, spatial_hash_cell_size=2.0,
        ignore_static_collision=ignore_static, log_level="error"))


def add_obstacles(sim: MultiRobotSimulationCore, obstacles: list[dict[str, Any]]) -> None:
    for o in obstacles:
        if o["kind"] == "box":
            shape = ShapeParams(shape_type="box", half_extents=[o["sx"] / 2, o["sy"] / 2, o["h"] / 2])
        else:
            shape = ShapeParams(shape_type="cylinder", radius=o["r"], height=o["h"])
        SimObject.from_params(SimObjectSpawnParams(
            visual_shape=shape, collision_shape=shape, initial_pose=Pose.from_yaw(o["x"], o["y"], o["h"] / 2, o["yaw"]),
            mass=0.0, collision_mode=CollisionMode.STATIC, name=o["name"]), sim_core=sim)


def robot_params(scene: dict[str, Any], x: float, y: float, yaw: float) -> AgentSpawnParams:
    lim = scene["limits"]
    controller = {"type": "differential", "max_linear_vel": lim["v"], "max_linear_accel": lim["a"],
                  "max_angular_vel": lim["w"], "max_angular_accel": lim["alpha"], "navigation_2d": True}
    if scene["robot"] == "urdf":
        return AgentSpawnParams(urdf_path=scene["urdf"], initial_pose=Pose.from_yaw(x, y, scene["urdf_z"], yaw),
                                collision_mode=CollisionMode.NORMAL_2D, controller=controller)
    hx, hy, hz = scene["box_half"]
    shape = ShapeParams(shape_type="box", half_extents=[hx, hy, hz])
    return AgentSpawnParams(visual_shape=shape, collision_shape=shape, mass=scene["mass"],
                            initial_pose=Pose.from_yaw(x, y, scene["box_z"], yaw),
                            collision_mode=CollisionMode.NORMAL_2D, controller=controller)


def random_path(rng: np.random.Generator, x: float, y: float, z: float, half: float) -> list[Pose]:
    """Random legs of 2–6 m in random directions, kept inside the walls."""
    path = []
    for _ in range(WAYPOINTS):
        heading, length = rng.uniform(-math.pi, math.pi), rng.uniform(2.0, 6.0)
        x = float(np.clip(x + length * math.cos(heading), -half + 1.0, half - 1.0))
        y = float(np.clip(y + length * math.sin(heading), -half + 1.0, half - 1.0))
        path.append(Pose.from_xyz(x, y, z))
    return path


def run(scene: dict[str, Any]) -> dict[str, Any]:
    rng = np.random.default_rng(scene["seed"])
    sim = make_sim(ignore_static=not scene["check_obstacles"])
    add_obstacles(sim, scene["obstacles"])
    mgr = AgentManager(sim_core=sim, fleet_controller={"type": "batch_differential"})
    t0 = time.perf_counter()
    agents = mgr.spawn_objects_batch([robot_params(scene, *pose) for pose in scene["robots"]])
    spawn_s = time.perf_counter() - t0
    z = scene["urdf_z"] if scene["robot"] == "urdf" else scene["box_z"]
    for agent in agents:
        pos = agent.get_pose().position
        agent.set_path(random_path(rng, float(pos[0]), float(pos[1]), z, scene["half"]))
    sim.initialize_simulation()
    ids = [a.object_id for a in agents]
    for _ in range(scene["warmup"]):
        sim.step_once()
    prev = np.hstack(sim.get_poses(ids))
    moved = 0.0
    wall = cpu = 0.0
    for _ in range(scene["steps"]):
        t0, c0 = time.perf_counter(), time.process_time()
        sim.step_once()
        wall += time.perf_counter() - t0
        cpu += time.process_time() - c0
        cur = np.hstack(sim.get_poses(ids))  # outside the timed region: how many robots moved (or turned)
        moved += float(np.mean(np.any(np.abs(cur - prev) > 1e-9, axis=1)))
        prev = cur
    return {"version": metadata.version("pybullet-fleet"), "robots": len(agents), "steps": scene["steps"],
            "dt": 0.1, "wall_s": wall, "cpu_s": cpu, "spawn_s": spawn_s,
            "moved_fraction": moved / max(1, scene["steps"]), "collisions_started": sim.collision_count,
            "active_pairs_end": len(sim.get_active_collision_pairs()),
            "moving_end": sum(bool(a.is_moving) for a in agents)}


if __name__ == "__main__":
    with open(sys.argv[1], encoding="utf-8") as fh:
        print(json.dumps(run(json.load(fh))))
