"""Many runs: files × seeds, in this process (`jobs=1`) or in `jobs` worker processes, a progress bar per run.

Outputs: `<out>/<mission>/` per run (`<out>/<mission>/seed-<s>/` with several seeds), plus `<out>/junit.xml`
(every run) and `<out>/summary.json` (per mission: pass rate and the spread of each assertion's figure).
"""

from __future__ import annotations

import json
import multiprocessing as mp
import queue
import statistics
import time
import traceback
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

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
            name, base = _name_and_seed(path)
        except FleetError:
            name, base = Path(path).stem, 0
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
                                   time_limit))
    return reqs


def _name_and_seed(path: str) -> tuple[str, int]:
    m = load_mission(path)
    return m.name, m.seed


def run_batch(reqs: list[RunRequest], jobs: int = 1, show_progress: bool = True) -> list[RunOutcome]:
    with Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.fields[sim]}"),
                  TimeElapsedColumn(), disable=not show_progress, transient=False) as bar:
        ids = [bar.add_task(Path(r.path).stem + (f" seed {r.seed}" if r.seed is not None else ""), total=1.0, sim="")
               for r in reqs]

        def show(i: int, t: float, limit: float) -> None:
            bar.update(ids[i], completed=min(1.0, t / limit), sim=f"{t:6.1f}/{limit:g} s sim")

        if jobs <= 1:
            return [_finish(bar, ids[i], run_file(r, progress=lambda t, lim, i=i: show(i, t, lim)))
                    for i, r in enumerate(reqs)]
        return _parallel(reqs, jobs, bar, ids, show)


def _parallel(reqs: list[RunRequest], jobs: int, bar: Progress, ids: list[Any], show: Any) -> list[RunOutcome]:
    # Not fork: the parent may hold PyBullet clients and foxglove runtime threads. A fork server that has
    # imported the runner once forks clean workers without paying the imports again.
    ctx = mp.get_context("forkserver")
    ctx.set_forkserver_preload(["fleet.missions.runner"])
    q: Any = ctx.Queue()
    results: list[RunOutcome | None] = [None] * len(reqs)
    with ProcessPoolExecutor(max_workers=jobs, mp_context=ctx, initializer=_init_worker, initargs=(q,)) as pool:
        futures: dict[Future[RunOutcome], int] = {pool.submit(_worker, i, r): i for i, r in enumerate(reqs)}
        pending = set(futures)
        while pending:
            done, pending = wait(pending, timeout=0.1, return_when=FIRST_COMPLETED)
            _drain(q, show)
            for f in done:
                results[futures[f]] = _finish(bar, ids[futures[f]], f.result())
        _drain(q, show)
    return [r for r in results if r is not None]


_QUEUE: Any = None


def _init_worker(q: Any) -> None:
    global _QUEUE
    _QUEUE = q


def _worker(i: int, req: RunRequest) -> RunOutcome:
    try:
        return run_file(req, progress=lambda t, limit: _QUEUE.put((i, t, limit)))
    except Exception as exc:  # one broken run must not take the batch down: it is reported as failed
        return _failed(req, Path(req.out_dir), f"{type(exc).__name__}: {exc}\n{traceback.format_exc()}", 0.0, "crash")


def _drain(q: Any, show: Any) -> None:
    while True:
        try:
            i, t, limit = q.get_nowait()
        except queue.Empty:
            return
        show(i, t, limit)


def _finish(bar: Progress, task: Any, out: RunOutcome) -> RunOutcome:
    verdict = "[green]PASS[/]" if out.passed else "[red]FAIL[/]"
    bar.update(task, completed=1.0, description=f"{verdict} {bar.tasks[task].description}")
    return out


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
