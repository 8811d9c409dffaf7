"""BARN as a suite: every (world, run) job through a small local process pool, results.jsonl + summary.json.

`map_jobs(fn, jobs, workers)` is the one place that runs jobs; it takes any picklable top-level function of
one job, so an executor with the same shape (a list of picklable jobs → results, in order) can replace it.
"""

from __future__ import annotations

import json
import math
import multiprocessing as mp
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any, TypeVar

from fleet.grading.barn import find_pairs
from fleet.grading.barn_run import BarnJob, check_controller, run_barn_job
from sim.robot_spec import RobotSpec

J = TypeVar("J")
R = TypeVar("R")


def map_jobs(fn: Callable[[J], R], jobs: Sequence[J], workers: int = 1) -> Iterator[R]:
    """Results of fn(job) in job order; `workers` > 1 runs them in that many spawned processes."""
    if workers <= 1 or len(jobs) <= 1:
        for job in jobs:
            yield fn(job)
        return
    with ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context("spawn")) as pool:
        yield from pool.map(fn, jobs)


def make_jobs(worlds_dir: Path, *, spec: RobotSpec, ids: list[int] | None = None,
              controller: str = "builtin:footprint_dwa",
              runs: int = 1, nav: dict[str, Any] | None = None, control_hz: float = 10.0) -> list[BarnJob]:
    name = check_controller(controller)
    data = spec.model_dump()
    return [BarnJob(p.id, str(p.world), str(p.path), data, name, dict(nav or {}), run=k, seed=k,
                    control_hz=control_hz)
            for p in find_pairs(worlds_dir, ids) for k in range(runs)]


def summarize_barn(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Success rate, mean BARN metric (failures count 0), counts by outcome, and timing."""
    n = len(rows)
    ok = [r for r in rows if r["success"]]
    wall = [r["wall_s"] for r in rows if "wall_s" in r]
    cpu = [r["cpu_s"] for r in rows if "cpu_s" in r]
    return {
        "metric": "BARN: success × T_opt / clip(T, 2·T_opt, 8·T_opt), T_opt = path-file length / 2.0 m/s",
        "runs": n, "worlds": len({r["world_id"] for r in rows}), "successes": len(ok),
        "success_rate": len(ok) / n if n else 0.0,
        "mean_barn_metric": sum(r["barn_metric"] for r in rows) / n if n else 0.0,
        "outcomes": dict(Counter(r["outcome"] for r in rows)),
        "collisions": sum(bool(r["collided"]) for r in rows),
        "mean_time_s": sum(r["time_s"] for r in ok) / len(ok) if ok else math.nan,
        "min_clearance": min((r["min_clearance"] for r in rows if not math.isnan(r["min_clearance"])),
                             default=math.nan),
        "wall_s_per_run": {"mean": sum(wall) / len(wall) if wall else math.nan, "max": max(wall, default=math.nan)},
        "cpu_s_per_run": {"mean": sum(cpu) / len(cpu) if cpu else math.nan, "max": max(cpu, default=math.nan)},
        "warnings": [f"world {r['world_id']}: the robot's lidar saw no obstacle in the whole run (mounted above "
                     "them?) — with map_source sensors it navigates blind" for r in rows
                     if r.get("lidar_returns_per_scan") == 0.0 and r.get("map_source") == "sensors"],
    }


def run_suite(jobs: list[BarnJob], out: Path, workers: int = 1,
              progress: Callable[[dict[str, Any]], None] | None = None) -> dict[str, Any]:
    """Run every job, append each row to OUT/results.jsonl as it lands, then write OUT/summary.json."""
    out.mkdir(parents=True, exist_ok=True)
    rows: list[dict[str, Any]] = []
    with (out / "results.jsonl").open("w", encoding="utf-8") as fh:
        for row in map_jobs(run_barn_job, jobs, workers):
            rows.append(row)
            fh.write(json.dumps(row) + "\n")
            fh.flush()
            if progress is not None:
                progress(row)
    summary = summarize_barn(rows)
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
    return summary
