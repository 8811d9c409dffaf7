"""Global planners only: success, planning time (median, p95) and path length vs the any-angle optimum.

Maps: configs/worlds/robot_arena.world and sim.worldgen.cluttered_arena at difficulty 1, 3 and 5
(fixed seeds). Per map, N random start/goal pairs (both free, ≥ 2 m apart, connected — "where a path
exists"). The baseline, measured in the same run on the same pairs, is Theta* (the optimal any-angle
grid path): its length is the denominator of the ratio. Every path is also checked with fcl against
the world geometry (not the planner's costmap): `collisions` counts paths that touch an obstacle.

    .venv/bin/python benchmarks/planners.py            # 100 pairs per map
    .venv/bin/python benchmarks/planners.py --quick    # 15 pairs per map
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from planning import FclWorld, LayeredCostmap, get_planner
from planning.global_planners.common import cell_of, check_reachable
from sim.errors import FleetError
from sim.robot_spec import RobotSpec
from sim.sdf_parser import parse_sdf
from sim.types import Pose2D, WorldDescription
from sim.worldgen import cluttered_arena

ROOT = Path(__file__).resolve().parent.parent
PLANNERS: list[tuple[str, dict[str, float | int]]] = [
    ("theta_star", {}),  # first: it is the baseline the others are measured against
    ("guided_theta_star", {}),
    ("astar", {}),
    ("rrt_connect", {"time_budget_s": 1.0, "seed": 1}),
    ("rrt_star", {"time_budget_s": 0.05, "seed": 1}),
    ("informed_rrt_star", {"time_budget_s": 0.05, "seed": 1}),
    ("bit_star", {"time_budget_s": 0.05, "seed": 1}),
    ("prm_star", {"time_budget_s": 0.05, "seed": 1}),
]


def maps() -> list[WorldDescription]:
    return [parse_sdf(ROOT / "configs/worlds/robot_arena.world"),
            *(cluttered_arena(seed=7, difficulty=d) for d in (1, 3, 5))]


def pairs(cm: LayeredCostmap, n: int, rng: np.random.Generator) -> list[tuple[Pose2D, Pose2D]]:
    xmin, ymin, xmax, ymax = cm.bounds
    out: list[tuple[Pose2D, Pose2D]] = []
    while len(out) < n:
        s, g = (Pose2D(*rng.uniform((xmin, ymin), (xmax, ymax))) for _ in range(2))
        if not (cm.is_free(s.x, s.y) and cm.is_free(g.x, g.y)) or s.distance_to(g) < 2.0:
            continue
        try:
            check_reachable(cm, cell_of(cm, s.x, s.y), cell_of(cm, g.x, g.y))
        except FleetError:
            continue  # no path exists: not a fair question for any planner
        out.append((s, g))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="15 pairs per map instead of 100")
    ap.add_argument("--pairs", type=int, default=None)
    args = ap.parse_args()
    n = args.pairs or (15 if args.quick else 100)
    radius = RobotSpec().footprint_radius
    print(f"robot radius {radius:.3f} m, resolution 0.05 m, {n} start/goal pairs per map (where a path exists)")
    print(f"{'map':24} {'planner':18} {'success':>8} {'median ms':>10} {'p95 ms':>8} "
          f"{'len/opt med':>11} {'p95':>6} {'max':>6} {'collisions':>10}")
    for world in maps():
        cm = LayeredCostmap.from_world(world, robot_radius=radius, resolution=0.05)
        fcl_world = FclWorld(world)
        queries = pairs(cm, n, np.random.default_rng(42))
        optimum: list[float] = []
        for name, kwargs in PLANNERS:
            times, ratios, ok, hits = [], [], 0, 0
            for k, (s, g) in enumerate(queries):
                try:
                    res = get_planner(name, **kwargs).plan(s, g, cm)
                except FleetError:
                    continue
                ok += 1
                times.append(res.planning_time_s * 1e3)
                if name == "theta_star":
                    optimum.append(res.length)
                if len(optimum) == len(queries):
                    ratios.append(res.length / optimum[k])
                hits += fcl_world.path_min_distance(res.path, radius, step=0.05) <= 0.0
            med, p95 = (np.median(times), np.percentile(times, 95)) if times else (np.nan, np.nan)
            rmed, rp95, rmax = ((np.median(ratios), np.percentile(ratios, 95), np.max(ratios))
                                if ratios else (np.nan, np.nan, np.nan))
            print(f"{world.name:24} {name:18} {100 * ok / len(queries):7.1f}% {med:10.2f} {p95:8.2f} "
                  f"{rmed:11.3f} {rp95:6.3f} {rmax:6.3f} {hits:10d}", flush=True)


if __name__ == "__main__":
    main()
