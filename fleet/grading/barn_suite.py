"""BARN as a suite: every (world, run) job on an executor (`fleet.executors`: local pool or Ray), results.jsonl
+ summary.json.

`map_jobs(fn, jobs, ...)` is the one place that runs jobs: `fleet.executors.run_map` over a picklable top-level
function of one job. A job whose run raised, timed out on its worker or was lost with its worker still gets a
row (outcome "error", the executor's reason), so a sweep always reports every world.
"""

from __future__ import annotations

import json
import math
from collections import Counter
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from fleet.executors import JobResult, JobState, run_map
from fleet.grading.barn import find_pairs
from fleet.grading.barn_run import BarnJob, check_controller, error_row, run_barn_job
from sim.robot_spec import RobotSpec

RUN_TIME_LIMIT_S = 900.0  # wall clock of one run on its worker: a run is ≤ 120 sim-s, far faster than real time


def map_jobs(fn: Callable[[BarnJob], dict[str, Any]], jobs: Sequence[BarnJob], workers: int | None = 1, *,
             executor: str = "local", ray_address: str | None = None, retries: int = 2,
             time_limit_s: float | None = RUN_TIME_LIMIT_S,
             on_row: Callable[[int, dict[str, Any]], None] | None = None) -> list[dict[str, Any]]:
    """One results row per job, in job order; `on_row(index, row)` on the driver as each lands."""

    def row_of(res: JobResult) -> dict[str, Any]:
        if res.state is JobState.DONE:
            return dict(res.value)
        why = res.error.strip().splitlines()[0] if res.error.strip() else "no result"
        return error_row(jobs[res.index], f"{res.state.value}: {why}")

    def landed(res: JobResult) -> None:
        if on_row is not None and res.state.final and res.state is not JobState.CANCELED:
            on_row(res.index, row_of(res))

    results = run_map(fn, jobs, executor=executor, jobs=workers, ray_address=ray_address, retries=retries,
                      time_limit_s=time_limit_s, label="BARN runs", show_progress=False,
                      key=lambda j: f"world_{j.world_id}/run_{j.run}", on_result=landed)
    return [row_of(r) for r in results if r.state is not JobState.CANCELED]


def make_jobs(worlds_dir: Path, *, spec: RobotSpec, ids: list[int] | None = None,
              controller: str = "builtin:footprint_dwa",
              runs: int = 1, nav: dict[str, Any] | None = None, control_hz: float = 10.0,
              agent: str = "", agent_limits: dict[str, Any] | None = None) -> list[BarnJob]:
    """One job per (world, run); with `agent` (a command) the agent drives instead of the builtin."""
    name = check_controller(controller)
    data = spec.model_dump()
    return [BarnJob(p.id, str(p.world), str(p.path), data, name, dict(nav or {}), run=k, seed=k,
                    control_hz=control_hz, agent=agent, agent_limits=dict(agent_limits or {}))
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


def run_suite(jobs: list[BarnJob], out: Path, workers: int | None = 1,
              progress: Callable[[dict[str, Any]], None] | None = None, *, executor: str = "local",
              ray_address: str | None = None, retries: int = 2) -> dict[str, Any]:
    """Run every job on the executor, append each row to OUT/results.jsonl as it lands (completion order, so
    a long sweep can be watched), then rewrite it in job order (the same file whatever ran where) and write
    OUT/summary.json."""
    out.mkdir(parents=True, exist_ok=True)
    with (out / "results.jsonl").open("w", encoding="utf-8") as fh:
        def landed(index: int, row: dict[str, Any]) -> None:
            fh.write(json.dumps(row) + "\n")
            fh.flush()
            if progress is not None:
                progress(row)

        rows = map_jobs(run_barn_job, jobs, workers, executor=executor, ray_address=ray_address,
                        retries=retries, on_row=landed)
    (out / "results.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows), encoding="utf-8")
    summary = summarize_barn(rows)
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
    return summary
