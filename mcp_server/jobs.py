"""Background jobs of the MCP front door (missions): each runs in its own thread with its own FleetService, so
the live world is untouched; the tool returns the job id at once and status calls read the progress."""

from __future__ import annotations

import itertools
import threading
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any

import anyio
from mcp.server.mcpserver import Context

from mcp_server.app import App, app_of
from sim.errors import ErrorCode, FleetError

MAX_RUNNING = 2


@dataclass
class Job:
    id: str
    kind: str
    source: str
    started_wall: float
    state: str = "running"  # running | succeeded | failed
    progress: dict[str, float] = field(default_factory=dict)
    result: Any = None
    error: str = ""


class JobRunner:
    def __init__(self) -> None:
        self._ids = itertools.count(1)
        self._lock = threading.Lock()
        self.jobs: dict[str, Job] = {}

    def start(self, kind: str, source: str, work: Callable[[Callable[[float, float], None]], Any]) -> Job:
        """Run `work(progress)` in a thread; `progress(done, total)` may be called from it."""
        with self._lock:
            if sum(j.state == "running" for j in self.jobs.values()) >= MAX_RUNNING:
                raise FleetError(ErrorCode.BUSY, f"{MAX_RUNNING} jobs are running already",
                                 "wait for one to finish (mission_status)")
            job = Job(f"{kind}{next(self._ids)}", kind, source, time.perf_counter())
            self.jobs[job.id] = job

        def progress(done: float, total: float) -> None:
            job.progress = {"done": round(done, 3), "total": round(total, 3)}

        def body() -> None:
            try:
                job.result = work(progress)
                job.state = "succeeded"
            except FleetError as exc:  # a refused input ends the job with the reason
                job.state, job.error = "failed", f"{exc.code.value}: {exc.message}"
            except Exception as exc:  # a bug: the job says so, and the thread's excepthook logs the traceback
                job.state, job.error = "failed", f"INTERNAL: {type(exc).__name__}: {exc}"
                raise
            finally:
                job.progress["wall_s"] = round(time.perf_counter() - job.started_wall, 3)

        threading.Thread(target=body, name=f"fleetnav-{job.id}", daemon=True).start()
        return job

    async def wait(self, job: Job, wall_s: float, report: Callable[[Job], Awaitable[None]]) -> None:
        """Wait up to `wall_s` wall seconds for the job to end, calling `report(job)` as it goes (progress)."""
        end = anyio.current_time() + wall_s
        while job.state == "running" and anyio.current_time() < end:
            await report(job)
            await anyio.sleep(0.1)

    def get(self, job_id: str) -> Job:
        if job_id not in self.jobs:
            raise FleetError(ErrorCode.NOT_FOUND, f"no job '{job_id}'",
                             f"jobs: {', '.join(self.jobs) or 'none'}")
        return self.jobs[job_id]


def jobs_of(app: App) -> JobRunner:
    """The server's one job runner (missions and challenges share it)."""
    runner = app.extras.get("jobs")
    if not isinstance(runner, JobRunner):
        runner = app.extras["jobs"] = JobRunner()
    return runner


def job_ref(job: Job) -> dict[str, Any]:
    return {"id": job.id, "state": job.state, "source": job.source}


async def await_job(ctx: Context, job_id: str, wait_s: float) -> Job:
    """The job, after waiting up to `wait_s` wall seconds for it to end, with MCP progress notifications."""
    runner = jobs_of(app_of(ctx))
    job = runner.get(job_id)

    async def report(j: Job) -> None:
        await ctx.report_progress(j.progress.get("done", 0.0), j.progress.get("total"), f"{j.id} {j.state}")

    await runner.wait(job, wait_s, report)
    return job
