"""Many runs: files × seeds, through an executor (fleet.executors: this process, a local pool of `jobs`
worker processes, or Ray), one progress bar for the sweep and a summary table at the end.

Outputs: `<out>/<mission>/` per run (`<out>/<mission>/seed-<s>/` with several seeds), plus `<out>/junit.xml`
(every run) and `<out>/summary.json` (per mission: pass rate and the spread of each assertion's figure).
"""

from __future__ import annotations

import json
import statistics
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from rich.console import Console

from fleet.executors import Job, JobResult, JobState, SweepProgress, make_executor, summary_table
from fleet.missions.loader import load_mission
from fleet.missions.report import junit_xml
from fleet.missions.runner import MissionRunner
from fleet.missions.types import RunOutcome
from sim.errors import FleetError


@dataclass(frozen=True)
class RunRequest:
    path: str
    seed: int | None
    out_dir: str
    record: bool = True
    time_limit: float | None = None
    memory_mb: int = 500  # what a scheduler reserves for the run (see memory_estimate_mb)


RUN_TIMEOUT_S = 900.0  # wall-clock limit of one run on its worker (a hung agent cannot hold a sweep forever)


def run_file(req: RunRequest, progress: Any = None, live: Any = None, pace: float | None = None) -> RunOutcome:
    """Load, apply overrides (seed, time limit) and run one mission; a load error is a failed run."""
    out = Path(req.out_dir)
    t0 = time.perf_counter()
    try:
        m = load_mission(req.path)
    except FleetError as exc:
        return _failed(req, out, exc.message, time.perf_counter() - t0, "load")
    update: dict[str, Any] = {}
    if req.seed is not None:
        update["seed"] = req.seed
    if req.time_limit is not None:
        update["time_limit"] = req.time_limit
    m = m.model_copy(update=update)
    return MissionRunner(m, out, source=req.path, record=req.record, progress=progress, live=live, pace=pace).run()


def plan_runs(paths: list[str], out_root: Path, seed: int | None, repeat: int, record: bool = True,
              time_limit: float | None = None) -> list[RunRequest]:
    reqs: list[RunRequest] = []
    used: set[str] = set()
    for path in paths:
        try:
            name, base, mem = _plan_one(path)
        except FleetError:
            name, base, mem = Path(path).stem, 0, BASE_MB
        stem = name
        k = 2
        while name in used:  # the same mission twice: keep both outputs
            name, k = f"{stem}-{k}", k + 1
        used.add(name)
        first = base if seed is None else seed
        seeds = [first + i for i in range(repeat)]
        for s in seeds:
            out = out_root / name / f"seed-{s}" if repeat > 1 else out_root / name
            reqs.append(RunRequest(path, s if (seed is not None or repeat > 1) else None, str(out), record,
                                   time_limit, mem))
    return reqs


def _plan_one(path: str) -> tuple[str, int, int]:
    m = load_mission(path)
    return m.name, m.seed, memory_estimate_mb(Path(m.world), len(m.robots))


BASE_MB, PER_ROBOT_MB, PER_WORLD_KB_MB = 400, 20, 0.5


def memory_estimate_mb(world: Path, robots: int) -> int:
    """What one run needs, for the scheduler: the interpreter with PyBullet, OMPL and GTSAM loaded, plus the
    world (its SDF size stands in for its meshes and costmaps) and the robots (see docs/benchmarks-missions.md
    for the measured peaks behind these constants)."""
    kb = world.stat().st_size / 1024 if world.is_file() else 0.0
    return int(BASE_MB + PER_ROBOT_MB * robots + PER_WORLD_KB_MB * kb)


def mission_job(req: RunRequest, scratch: Path) -> RunOutcome:
    """The executor's job: run into the worker's scratch folder (its files travel back as data)."""
    out = run_file(replace(req, out_dir=str(scratch)))
    out.out_dir = Path(req.out_dir)
    return out


def mission_jobs(reqs: list[RunRequest], run_timeout: float | None = RUN_TIMEOUT_S) -> list[Job]:
    return [Job(_label(r), mission_job, r, r.out_dir, memory_mb=r.memory_mb, time_limit_s=run_timeout) for r in reqs]


def run_batch(reqs: list[RunRequest], jobs: int | None = 1, show_progress: bool = True, *, executor: str = "local",
              ray_address: str | None = None, retries: int = 2, run_timeout: float | None = RUN_TIMEOUT_S,
              console: Console | None = None) -> list[RunOutcome]:
    """Every request through an executor (`local`: this process or a pool of `jobs` processes; `ray`), one
    progress bar for the sweep. Returns the finished runs in request order (a run that errored, timed out or
    whose worker kept dying is a failed run); after Ctrl-C, runs that did not finish are left out."""
    ex = make_executor(executor, jobs=jobs, ray_address=ray_address, retries=retries, preload=PRELOAD)
    with SweepProgress(len(reqs), label="missions", verdict=_verdict, show=show_progress, console=console) as bar:
        results = ex.run(mission_jobs(reqs, run_timeout), on_event=bar.event)
    if show_progress:
        (console or Console()).print(summary_table(results, _verdict, title="missions"))
    return [as_outcome(reqs[r.index], r) for r in results if r.state is not JobState.CANCELED]


PRELOAD = ("fleet.missions.runner",)


def as_outcome(req: RunRequest, res: JobResult) -> RunOutcome:
    if res.state is JobState.DONE:
        assert isinstance(res.value, RunOutcome)
        return res.value
    kind = {JobState.TIMEOUT: "timeout", JobState.LOST: "lost"}.get(res.state, "crash")
    return _failed(req, Path(req.out_dir), res.error or res.state.value, res.wall_s, kind)


def _verdict(res: JobResult) -> str:
    if res.state is JobState.DONE:
        return "pass" if res.value.passed else "fail"
    return res.state.value


def _label(r: RunRequest) -> str:
    return Path(r.path).stem + (f" seed {r.seed}" if r.seed is not None else "")


def _failed(req: RunRequest, out: Path, error: str, wall: float, kind: str) -> RunOutcome:
    out.mkdir(parents=True, exist_ok=True)
    seed = req.seed if req.seed is not None else 0
    report: dict[str, Any] = {"mission": Path(req.path).stem, "seed": seed, "passed": False,
              "end_time": 0.0, "ended_because": "error",
              "assertions": [{"name": kind, "type": kind, "passed": False, "measured": None,
                              "expected": "a valid mission file" if kind == "load" else "a run without errors",
                              "message": error.splitlines()[0],
                              "details": {}}],
              "wall": {"wall_s": round(wall, 3)}}
    (out / "report.json").write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    (out / "error.txt").write_text(error + "\n", encoding="utf-8")
    return RunOutcome(Path(req.path).stem, req.path, seed, False, report, out, wall, error.splitlines()[0])


def summarize(outcomes: list[RunOutcome]) -> dict[str, Any]:
    """Per mission: runs, pass rate, and each assertion's pass rate and measured spread across seeds."""
    by: dict[str, list[RunOutcome]] = {}
    for o in outcomes:
        by.setdefault(o.mission, []).append(o)
    out: dict[str, Any] = {}
    for name, runs in by.items():
        per: dict[str, list[dict[str, Any]]] = {}
        for o in runs:
            for a in o.report.get("assertions", []):
                per.setdefault(a["name"], []).append(a)
        out[name] = {"runs": len(runs), "seeds": [o.seed for o in runs],
                     "pass_rate": sum(o.passed for o in runs) / len(runs),
                     "assertions": {k: _spread(v) for k, v in per.items()}}
    return out


def _spread(results: list[dict[str, Any]]) -> dict[str, Any]:
    vals = [r["measured"] for r in results if isinstance(r["measured"], int | float)]
    d: dict[str, Any] = {"pass_rate": sum(r["passed"] for r in results) / len(results)}
    if vals:
        d |= {"min": min(vals), "mean": statistics.fmean(vals), "max": max(vals),
              "stdev": statistics.pstdev(vals) if len(vals) > 1 else 0.0}
    return d


def write_batch_outputs(outcomes: list[RunOutcome], out_root: Path) -> None:
    out_root.mkdir(parents=True, exist_ok=True)
    (out_root / "junit.xml").write_text(junit_xml([o.report for o in outcomes]), encoding="utf-8")
    (out_root / "summary.json").write_text(json.dumps(summarize(outcomes), indent=2) + "\n", encoding="utf-8")
