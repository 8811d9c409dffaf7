"""Task allocation: total travel and makespan of Hungarian-in-rounds and the sequential auction against the
greedy baseline (each task in turn to the robot that can append it most cheaply), their distance from a
lower bound on any allocation's travel (the assignment relaxation, fleet/allocation/bound.py), and solve times.

World: configs/worlds/warehouse.world (40 × 40 m, shelf rows, 4 docks). 50 robots × 200 go_to tasks at
random free places (fixed seed), all three methods on the same robots and tasks, costs = grid shortest
paths (0.2 m grid) around the shelves. Multiple tasks per robot: Hungarian assigns in rounds (one task
per robot per round, appended to its plan); the auction sells one task per round to the lowest marginal
bid; greedy takes tasks in order. Nothing moves (dry_run).

Scenarios:
  plain        full batteries, no priorities or time windows
  constrained  a 10 Wh battery with charge uniform in [0.2, 0.6] (so charge stops get inserted), 20 % of
               tasks priority 1, 20 % with a deadline 60–400 s ahead, 10 % not before 0–120 s

    .venv/bin/python benchmarks/allocation.py            # 50 robots × 200 tasks
    .venv/bin/python benchmarks/allocation.py --quick    # 10 robots × 40 tasks
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from fleet import BatteryConfig, FleetConfig, FleetService
from planning import LayeredCostmap
from sim import Pose2D

METHODS = ("greedy", "hungarian", "hungarian_rounds", "auction")  # greedy first: the baseline


def free_points(svc: FleetService, n: int, rng: np.random.Generator, min_sep: float) -> np.ndarray:
    """n random points with room for a robot (0.3 m margin), at least min_sep apart."""
    cm = LayeredCostmap.from_world(svc.world.description, robot_radius=svc.default_spec().footprint_radius + 0.3,
                                   resolution=0.1)
    rows, cols = np.nonzero(cm.free_mask)
    x0, y0, _, _ = cm.bounds
    cand = np.column_stack([x0 + (cols + 0.5) * 0.1, y0 + (rows + 0.5) * 0.1])[rng.permutation(len(rows))]
    out: list[np.ndarray] = []
    for p in cand:
        if all(np.hypot(*(p - q)) >= min_sep for q in out):
            out.append(p)
            if len(out) == n:
                break
    return np.array(out)


def scenario(name: str, n_robots: int, n_tasks: int, seed: int) -> tuple[FleetService, list[dict[str, Any]]]:
    rng = np.random.default_rng(seed)
    battery = BatteryConfig(capacity_wh=10.0) if name == "constrained" else BatteryConfig()
    svc = FleetService(FleetConfig(world="warehouse", seed=seed, battery=battery))
    for i, (x, y) in enumerate(free_points(svc, n_robots, rng, min_sep=1.2)):
        svc.spawn_robot(f"r{i}", Pose2D(float(x), float(y), float(rng.uniform(-np.pi, np.pi))))
        if name == "constrained":
            svc.set_battery(f"r{i}", float(rng.uniform(0.2, 0.6)))
    tasks: list[dict[str, Any]] = []
    for x, y in free_points(svc, n_tasks, rng, min_sep=0.3):
        t: dict[str, Any] = {"type": "go_to", "params": {"goal": {"x": float(x), "y": float(y)}}}
        if name == "constrained":
            u = rng.uniform()
            if u < 0.2:
                t["priority"] = 1
            elif u < 0.4:
                t["deadline"] = float(rng.uniform(60.0, 400.0))
            elif u < 0.5:
                t["earliest_start"] = float(rng.uniform(0.0, 120.0))
        tasks.append(t)
    return svc, tasks


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="10 robots × 40 tasks")
    ap.add_argument("--seed", type=int, default=7)
    args = ap.parse_args()
    n_r, n_t = (10, 40) if args.quick else (50, 200)
    print(f"allocation on warehouse.world: {n_r} robots × {n_t} go_to tasks, grid path costs (0.2 m), seed {args.seed}")
    print(f"{'scenario':<12} {'method':<16} {'assigned':>8} {'infeas':>6} {'charges':>7} {'travel m':>9} "
          f"{'vs greedy':>9} {'vs bound':>8} {'makespan s':>10} {'vs greedy':>9} {'solve s':>8} {'table s':>8}")
    for name in ("plain", "constrained"):
        svc, tasks = scenario(name, n_r, n_t, args.seed)
        t0 = time.perf_counter()
        svc.assign_tasks(tasks[:1], dry_run=True)  # builds the grid (rasterise, graph, EDT) once per world
        grid_s = time.perf_counter() - t0
        base: dict[str, float] = {}
        for method in METHODS:
            a = svc.assign_tasks(tasks, method=method, dry_run=True)
            base = base or {"travel": a.travel_m, "makespan": a.makespan_s}
            charges = sum(x.charge_dock is not None for x in a.assignments)
            print(f"{name:<12} {method:<16} {len(a.assignments):>8} {len(a.infeasible):>6} {charges:>7} "
                  f"{a.travel_m:>9.1f} {100 * (a.travel_m / base['travel'] - 1):>+8.1f}% "
                  f"{100 * (a.travel_m / a.travel_lower_bound_m - 1):>+7.1f}% "
                  f"{a.makespan_s:>10.1f} {100 * (a.makespan_s / base['makespan'] - 1):>+8.1f}% "
                  f"{a.solve_time_s:>8.3f} {a.table_time_s:>8.3f}")
        print(f"{'':<12} (travel lower bound, assignment relaxation: {a.travel_lower_bound_m:.1f} m; "
              f"one-off grid build for the world: {grid_s:.2f} s)")
        svc.close()


if __name__ == "__main__":
    main()
