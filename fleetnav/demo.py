"""`fleetnav demo`: load a world, spawn robots, drive them with a lidar-reactive wanderer, print a summary."""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table


def _free_spawn_poses(world: object, n: int) -> list[tuple[float, float, float]]:
    from sim import World

    assert isinstance(world, World)
    desc = world.description
    poses = [(sp.pose.x, sp.pose.y, sp.pose.yaw) for sp in desc.spawn_points]
    xmin, ymin, xmax, ymax = desc.bounds(margin=-0.8)
    while len(poses) < 4 * n + 50:  # candidates: spawn points first, then random free spots
        poses.append((float(world.rng.uniform(xmin, xmax)), float(world.rng.uniform(ymin, ymax)),
                      float(world.rng.uniform(-math.pi, math.pi))))
    return poses


def run_demo(world_file: Path, *, robots: int, seconds: float, fidelity: str, seed: int) -> int:
    from sim import FleetError, Pose2D, World

    console = Console()
    try:
        world = World.from_sdf(world_file, physics_hz=100, seed=seed, fidelity=fidelity)
    except FleetError as exc:
        console.print(f"[red]error[/red] {exc}")
        return 2
    names: list[str] = []
    for x, y, yaw in _free_spawn_poses(world, robots):
        if len(names) == robots:
            break
        try:
            names.append(world.spawn_robot(f"robot{len(names)}", Pose2D(x, y, yaw)))
        except FleetError:
            continue  # occupied spot: try the next candidate
    console.print(f"world [bold]{world.name}[/bold] ({world_file}): {len(world.models.names())} models, "
                  f"{len(world.description.lights)} lights; spawned {len(names)} {fidelity} robots")
    start = {n: world.robot_pose(n) for n in names}
    travelled = dict.fromkeys(names, 0.0)
    collisions = dict.fromkeys(names, 0)
    min_range = dict.fromkeys(names, math.inf)
    wall0 = time.perf_counter()
    while world.time < seconds:
        for n in names:
            scan = world.latest_scan(n)
            v, w = 0.5, 0.0
            if scan is not None:
                ranges = scan.ranges
                front = np.concatenate([ranges[:30], ranges[-30:]]) if ranges.size == 360 else ranges
                ahead = float(np.min(front))
                min_range[n] = min(min_range[n], float(np.min(ranges)))
                if ahead < 1.0:  # turn toward the side with more room
                    left, right = float(np.mean(np.minimum(ranges[180:270], 10))), float(
                        np.mean(np.minimum(ranges[90:180], 10)))
                    v, w = 0.05, (1.5 if left > right else -1.5)
            world.set_cmd_vel(n, v, w)
        before = {n: world.robot_pose(n) for n in names}
        world.run_for(0.1)
        for n in names:
            travelled[n] += before[n].distance_to(world.robot_pose(n))
            collisions[n] += int(world.robot_in_collision(n))
    wall = time.perf_counter() - wall0
    table = Table(title=f"{seconds:.0f} s of sim time in {wall:.2f} s wall ({seconds / wall:.1f}× real time)")
    for col in ("robot", "start", "end", "travelled m", "closest lidar m", "blocked steps"):
        table.add_column(col)
    for n in names:
        s, e = start[n], world.robot_pose(n)
        table.add_row(n, f"({s.x:.2f}, {s.y:.2f})", f"({e.x:.2f}, {e.y:.2f})", f"{travelled[n]:.2f}",
                      f"{min_range[n]:.2f}", str(collisions[n]))
    console.print(table)
    world.close()
    return 0
