"""benchmarks/fleet.py --traffic: the PIBT traffic layer (fleet/traffic) on warehouse.world, random go-to tasks.

Robots spawn at random distinct free traffic cells; each gets a random free goal cell ≥ 3 m away and a new one
the moment it arrives (lifelong). Collisions are counted by an independent check after every physics step
from ground-truth poses: robot-robot where two footprint circles (radius = the spec's footprint radius)
overlap, robot-obstacle where a footprint circle reaches a static obstacle on the occupancy grid; episodes
are counted per pair (a pair touching on consecutive steps is one episode). The kinematic world itself never
lets bodies interpenetrate (it reverts a colliding robot's step), so the check counts a pair as touching when
its footprint circles come within 1 mm (`TOUCH_M`), and the world's own contact flags are counted beside it.
Also reported: wall time and CPU time of the loop, the load average before and after, the longest wait, and the
waits split into cycles and queues (_wait_cycles.py; its sampling time is taken out of the loop's times, so the
real-time factor is the service's and the collision check's as before).
"""

from __future__ import annotations

import os
import time
from typing import Any

import numpy as np
from _wait_cycles import WaitClassifier
from scipy.spatial import cKDTree

from fleet import FleetConfig, FleetService
from fleet.traffic import enable_traffic
from sim import Pose2D

TOUCH_M = 1e-3  # footprint circles closer than this count as touching


def seconds_or_off(text: str) -> float | None:
    """A command-line duration in seconds, or `off` (None)."""
    return None if text == "off" else float(text)


def latency_summary(latency: list[float], open_ages: list[float]) -> dict[str, float]:
    """Task latency (given -> reached, s) of the tasks done, and the oldest task still open at the end."""
    lat = np.asarray(latency) if latency else np.zeros(1)
    return {"latency_p50_s": float(np.percentile(lat, 50)), "latency_p95_s": float(np.percentile(lat, 95)),
            "latency_max_s": float(lat.max()), "oldest_open_task_s": max(open_ages, default=0.0)}


def run_traffic(n: int, minutes: float, seed: int, model: str, *, cell: float = 1.0, speed: float = 0.8,
                physics_hz: float = 50.0, window: int = 1, lidar: str = "360 beams 10 Hz",
                priority: str = "goal_age", urgent_s: float | None = 10.0, yield_aside: bool = True,
                highway: float = 4.0, lane_cost: float = 3.0, push_frozen: bool = True,
                congestion: float = 0.0, urgent_rank: str = "since_progress",
                withdraw: str = "crowded", flush_s: float = 1.0, admission: str = "bound",
                urgent_cells: int | None = 3, one_way: bool = True, urgent_window: int = 1,
                keep_clear: bool = True, keep_clear_s: float = 4.0, held_clear: bool = True,
                hold_ground_s: float | None = 5.0) -> dict[str, Any]:
    svc = FleetService(FleetConfig(world="warehouse", seed=seed, physics_hz=physics_hz, control_hz=10.0,
                                   costmap_resolution=0.1, avoidance={"type": "orca"}, robot_model=model))
    try:
        rng = np.random.default_rng(seed)
        tm0 = enable_traffic(svc, cell=cell, speed=speed, seed=seed, window=window, priority=priority,
                             urgent_s=urgent_s, yield_aside=yield_aside, highway=highway, lane_cost=lane_cost,
                             push_frozen=push_frozen, congestion=congestion,
                             urgent_rank=urgent_rank, withdraw=withdraw, flush_s=flush_s,
                             admission=admission, urgent_cells=urgent_cells, one_way=one_way,
                             urgent_window=urgent_window, keep_clear=keep_clear, keep_clear_s=keep_clear_s,
                             held_clear=held_clear, hold_ground_s=hold_ground_s)
        grid = tm0.grid
        cells = rng.choice(len(grid), size=n, replace=False)
        names = [f"t{k:03d}" for k in range(n)]
        for name, node in zip(names, cells.tolist(), strict=True):
            x, y = grid.xy[node]
            svc.spawn_robot(name, Pose2D(float(x), float(y), float(rng.choice([0, np.pi / 2, np.pi, -np.pi / 2]))))
        dist_ok = lambda a, b: np.hypot(*(grid.xy[a] - grid.xy[b])) >= 3.0  # noqa: E731

        def new_goal(name: str, _: float = 0.0) -> None:
            i = tm.names.index(name)
            while True:
                g = int(rng.integers(len(grid)))
                if dist_ok(g, int(tm.sched.tail[i])):
                    given[name] = svc.world.time
                    tm.go(name, *grid.xy[g])
                    return

        tm = tm0
        done: list[float] = []
        given: dict[str, float] = {}
        latency: list[float] = []  # task given -> reached, including time held by admission

        def reached(name: str, now: float) -> None:
            done.append(now)
            latency.append(now - given[name])
            new_goal(name)

        def start() -> None:
            for name in names:
                tm.add(name)
            for name in names:
                new_goal(name)

        svc.call(start)
        tm.on_reached = reached
        waits = WaitClassifier(tm)  # the waits split into cycles (deadlocks) and queues (_wait_cycles.py)
        r = tm.radius
        clearance = svc.static_clearance()
        pairs_now: set[tuple[int, int]] = set()
        walls_now: set[int] = set()
        episodes = {"robot": 0, "obstacle": 0, "world_contacts": 0}
        in_contact: set[int] = set()
        closest = {"robot": np.inf, "obstacle": np.inf}
        rows = [svc.world.table.index(nm) for nm in names]

        def check() -> None:
            nonlocal pairs_now, walls_now, in_contact
            f = svc.world.table.f
            hit_world = set(np.flatnonzero(svc.world.table.b["in_collision"][rows]).tolist())
            episodes["world_contacts"] += len(hit_world - in_contact)
            in_contact = hit_world
            xy = np.column_stack([f["x"][rows], f["y"][rows]])
            near = cKDTree(xy).query_pairs(2 * r + 0.2, output_type="ndarray")
            if len(near):
                d = np.hypot(*(xy[near[:, 0]] - xy[near[:, 1]]).T)
                closest["robot"] = min(closest["robot"], float(d.min()) - 2 * r)
                hit = {(int(a), int(b)) for (a, b), dd in zip(near, d, strict=True) if dd < 2 * r + TOUCH_M}
            else:
                hit = set()
            episodes["robot"] += len(hit - pairs_now)
            pairs_now = hit
            c = clearance.query(xy)[0] - r
            closest["obstacle"] = min(closest["obstacle"], float(c.min()))
            wall = set(np.flatnonzero(c < TOUCH_M).tolist())
            episodes["obstacle"] += len(wall - walls_now)
            walls_now = wall
            waits.sample(svc.world.time)

        svc.step_listeners.append(check)
        load0 = os.getloadavg()[0]
        t0, c0 = time.perf_counter(), time.process_time()
        end = minutes * 60.0
        while svc.world.time < end - 1e-9:
            svc.advance(min(5.0, end - svc.world.time))
        wall, cpu = time.perf_counter() - t0 - waits.wall_s, time.process_time() - c0 - waits.cpu_s
        d = tm.describe()
        in_progress = int(np.count_nonzero(tm.pending))
        return {"robots": n, "avoidance": f"traffic (PIBT+ADG, {priority}, urgent_s {urgent_s}, "
                f"yield_aside {yield_aside}, highway {highway:g}, lane_cost {lane_cost:g}, push_frozen {push_frozen}, "
                f"congestion {congestion:g}, urgent_rank {urgent_rank}, "
                f"window {window} (urgent {urgent_window}), withdraw {withdraw}, admission {admission}, "
                f"urgent_cells {urgent_cells}, "
                f"one_way {one_way}, keep_clear {keep_clear} ({keep_clear_s:g} s), held_clear {held_clear}, "
                f"hold_ground_s {hold_ground_s}"
                f"{f' every {flush_s:g} s' if withdraw == 'flush' else ''}), "
                f"lidar {lidar}",
                "sim_min": minutes,
                "done": len(done),
                "done_per_min": len(done) / minutes, "failed": 0, "in_progress": in_progress,
                "robot_collisions": episodes["robot"], "obstacle_hits": episodes["obstacle"],
                "closest_robot_gap_m": closest["robot"], "closest_obstacle_gap_m": closest["obstacle"],
                "deadlocks": d["deadlocks"], "resolved": d["resolved"], "unresolved": d["open_deadlocks"],
                "longest_deadlock_s": d["longest_deadlock_s"],
                "longest_open_s": d["longest_open_deadlock_s"], "fields_computed": d["fields_computed"],
                **waits.summary(svc.world.time), "classify_cpu_s": waits.cpu_s,
                "world_contacts": episodes["world_contacts"],
                "layer_ms_per_tick": 1000 * d["cpu_s"] / max(d["ticks"], 1), "pibt_steps": d["steps"],
                "withdrawn": d["withdrawn"],
                **latency_summary(latency, [svc.world.time - t for nm, t in given.items()
                                            if tm.pending[tm.names.index(nm)] or tm.held(nm)]),
                "admission_limit": d["admission_limit"], "lowest_limit": d.get("lowest_limit", np.inf),
                "held_now": d["held_now"], "urgent_now": d["urgent_now"],
                "longest_hold_s": d.get("longest_hold_s", 0.0),
                "rtf": svc.world.time / wall,
                "rtf_cpu": svc.world.time / cpu, "wall_s": wall, "cpu_s": cpu,
                "load": f"{load0:.1f}-{os.getloadavg()[0]:.1f}"}
    finally:
        svc.close()
