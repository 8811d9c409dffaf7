"""A generated set of cluttered arenas at graded difficulty, each measured the way BARN characterises its
worlds (Perille et al. 2020): how cramped the way is and how winding. The set is ranked by a difficulty
index over a pool of generated arenas, as BARN ranks its 300 worlds.

Metrics of one arena, all on the robot's optimal path (grading.score.optimal_path):
- `min_clearance` / `mean_clearance`: footprint-radius disc to the nearest obstacle along the path, m;
- `tortuosity`: optimal path length / straight-line distance (1 = straight);
- `fill`: share of the arena's floor covered by obstacles; `obstacles`: how many.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from fleet.grading.challenge import CHALLENGES
from fleet.grading.score import optimal_path
from planning import LayeredCostmap, rasterize_world
from planning.collision import sample_path
from sim.errors import ErrorCode, FleetError
from sim.types import WorldDescription
from sim.worldgen import cluttered_arena

DEFAULT_SIZE = 10.0  # m, as the course arena: large enough for a few turns, small enough to run fast
DEFAULT_V_MAX = 1.0  # m/s of the default diffbot, for the suggested time limit
DEFAULT_RADIUS = 0.3363  # m, the default diffbot's footprint radius


@dataclass(frozen=True)
class ArenaInfo:
    name: str
    seed: int
    difficulty: int
    size: float
    obstacles: int
    fill: float
    optimal_length: float
    straight_distance: float
    tortuosity: float
    min_clearance: float
    mean_clearance: float
    time_limit: float

    def to_dict(self) -> dict[str, Any]:
        return {k: round(v, 4) if isinstance(v, float) else v for k, v in asdict(self).items()}


def measure(desc: WorldDescription, *, seed: int, difficulty: int, size: float, robot_radius: float = DEFAULT_RADIUS,
            v_max: float = DEFAULT_V_MAX) -> ArenaInfo:
    start = desc.spawn_points[0].pose
    goal = next(m.pose.to_2d() for m in desc.models if m.name == "goal_marker")
    plan = optimal_path(desc, start, goal, robot_radius=robot_radius)
    costmap = LayeredCostmap.from_world(desc, robot_radius=robot_radius, padding=0.0, margin=0.0)
    pts = np.array([[p.x, p.y] for p in sample_path(plan.path, 0.05)] + [plan.path[-1].tolist()])
    clear = costmap.clearance_many(pts) - robot_radius
    grid = rasterize_world(desc, resolution=0.05, margin=0.0)
    h = size / 2
    rows, cols = grid.world_to_cells(np.array([[-h + 0.01, -h + 0.01], [h - 0.01, h - 0.01]]))
    inner = grid.occupied()[rows[0]:rows[1] + 1, cols[0]:cols[1] + 1]
    straight = start.distance_to(goal)
    t_opt = plan.length / v_max
    return ArenaInfo(desc.name, seed, difficulty, size, sum(m.name.startswith("obstacle_") for m in desc.models),
                     float(inner.mean()), plan.length, straight, plan.length / straight, max(float(clear.min()), 0.0),
                     float(clear.mean()), float(10 * math.ceil(8 * t_opt / 10)))


def candidates(levels: tuple[int, ...] = (1, 2, 3, 4, 5), per_level: int = 8,
               size: float = DEFAULT_SIZE) -> list[ArenaInfo]:
    """Arenas of each obstacle-density level, seeds 100·level + 0..per_level-1, measured."""
    return [measure(cluttered_arena(100 * d + s, d, size), seed=100 * d + s, difficulty=d, size=size)
            for d in levels for s in range(per_level)]


def difficulty_index(info: ArenaInfo) -> float:
    """Winding and cramped is hard: tortuosity / mean clearance along the optimal path, 1/m."""
    return info.tortuosity / max(info.mean_clearance, 1e-3)


def generate(count: int = 5, pool: list[ArenaInfo] | None = None) -> list[ArenaInfo]:
    """`count` arenas graded by difficulty: the pool (default: 8 seeds at each of the generator's 5 density
    levels) ranked by difficulty_index, one arena taken at each of `count` evenly spaced quantiles. Density
    alone grades only on average (a dense arena may still leave a wide diagonal), the index grades what a
    robot feels."""
    ranked = sorted(pool if pool is not None else candidates(), key=difficulty_index)
    if count < 1 or count > len(ranked):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"count must be 1..{len(ranked)}, got {count}")
    return [ranked[round((k + 0.5) * len(ranked) / count - 0.5)] for k in range(count)]


def challenge_doc(info: ArenaInfo, rank: int, runs: int = 3) -> dict[str, Any]:
    """The challenge file of one arena (time limit 8·T_opt rounded up: slower than that scores the floor)."""
    return {"name": f"cluttered_{rank}",
            "description": f"generated cluttered arena, difficulty rank {rank} (index "
                           f"{difficulty_index(info):.2f}/m): tortuosity {info.tortuosity:.3f}, mean clearance "
                           f"{info.mean_clearance:.2f} m, min clearance {info.min_clearance:.2f} m, "
                           f"fill {info.fill:.1%}",
            "arena": {"seed": info.seed, "difficulty": info.difficulty, "size": info.size},
            "start": "spawn_start", "goal": "goal_marker", "success_radius": 0.5, "time_limit": info.time_limit,
            "collision": "end", "runs": runs}


def write_challenges(infos: list[ArenaInfo], out_dir: Path = CHALLENGES) -> list[Path]:
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for rank, info in enumerate(infos, 1):
        doc = challenge_doc(info, rank)
        path = out_dir / f"{doc['name']}.yaml"
        header = "# Generated by `fleetnav challenge arenas`; metrics: " + str(info.to_dict()) + "\n"
        path.write_text(header + yaml.safe_dump(doc, sort_keys=False), encoding="utf-8")
        paths.append(path)
    return paths


def table(infos: list[ArenaInfo]) -> str:
    """The set as a Markdown table."""
    lines = ["| challenge | arena seed | density level | obstacles | fill | optimal m | tortuosity | "
             "min clearance m | mean clearance m | index 1/m | time limit s |", "|" + "---|" * 11]
    lines += [f"| cluttered_{k} | {i.seed} | {i.difficulty} | {i.obstacles} | {i.fill:.1%} | {i.optimal_length:.2f} | "
              f"{i.tortuosity:.3f} | {i.min_clearance:.3f} | {i.mean_clearance:.3f} | {difficulty_index(i):.3f} | "
              f"{i.time_limit:g} |" for k, i in enumerate(infos, 1)]
    return "\n".join(lines)
