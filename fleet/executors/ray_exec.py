"""RayExecutor: each job is one Ray task with its resources declared (CPUs, memory), on a local Ray instance
started here (`address=None`, kept on 127.0.0.1) or on an existing cluster (`"auto"`, or `host:port`).

Ray's own task retries are off (`max_retries=0`): the driver retries a job whose worker or node died, up to
`retries` times, so it can count attempts and report each run once. At most `window` tasks are in flight, so
a Ctrl-C has little to cancel and the driver holds few results at a time.
"""

from __future__ import annotations

import logging
import os
from collections import deque
from typing import Any

from fleet.executors.base import Events, Job, JobResult, JobState, run_job
from fleet.executors.local import fill, finish
from sim.errors import ErrorCode, FleetError

INSTALL_HINT = "install the extra: pip install 'fleetnav[ray]' (or run with --executor local)"


def import_ray(loopback: bool = False) -> Any:
    """Ray, or a FleetError that says how to install it. `loopback`: a local instance will be started, so
    keep it on 127.0.0.1 (Ray reads this once, at import). Never sends usage statistics."""
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    if loopback:
        os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
    try:
        import ray
    except ImportError as exc:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, "--executor ray needs Ray, which is not installed",
                         INSTALL_HINT) from exc
    return ray


def fleetnav_job(index: int, job: Job) -> JobResult:
    """The Ray task (a module-level function, so workers import it by name; its name is the worker's title)."""
    return run_job(index, job)


class RayExecutor:
    def __init__(self, address: str | None = None, retries: int = 2, num_cpus: int | None = None,
                 window: int | None = None) -> None:
        self.address, self.retries, self.num_cpus, self.window = address, retries, num_cpus, window

    def connect(self) -> tuple[Any, bool]:
        """(ray, started_here). A local instance stays on loopback and sends no usage statistics."""
        ray = import_ray(loopback=self.address is None)
        if ray.is_initialized():
            return ray, False
        kw: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False, "logging_level": logging.WARNING}
        if self.address is None:
            kw |= {"num_cpus": self.num_cpus, "_node_ip_address": "127.0.0.1"}
        try:
            ray.init(address=self.address or "local", **kw)  # "local": a new instance, never a running one
        except ConnectionError as exc:
            raise FleetError(ErrorCode.NOT_FOUND, f"no Ray cluster at {self.address}: {exc}",
                             "start one with `ray start --head`, or omit --ray-address for a local instance") from exc
        return ray, True

    def run(self, jobs: list[Job], on_event: Events = None) -> list[JobResult]:
        ray, started = self.connect()
        try:
            return self._run(ray, jobs, on_event)
        finally:
            if started:
                ray.shutdown()

    def _run(self, ray: Any, jobs: list[Job], on_event: Events) -> list[JobResult]:
        task = ray.remote(max_retries=0)(fleetnav_job)
        window = self.window or max(2, 2 * int(ray.cluster_resources().get("CPU", 1)))
        results: list[JobResult | None] = [None] * len(jobs)
        attempts = [0] * len(jobs)
        todo = deque(range(len(jobs)))
        flying: dict[Any, int] = {}
        try:
            while todo or flying:
                while todo and len(flying) < window:
                    i = todo.popleft()
                    attempts[i] += 1
                    job = jobs[i]
                    ref = task.options(num_cpus=job.cpus, memory=job.memory_mb * 2**20).remote(i, job)
                    flying[ref] = i
                    if on_event:
                        on_event(i, JobState.RUNNING, None)
                done, _ = ray.wait(list(flying), num_returns=1, timeout=0.2)
                for ref in done:
                    i = flying.pop(ref)
                    try:
                        res: JobResult = ray.get(ref)
                    except ray.exceptions.RayTaskError as exc:  # run_job catches the job's errors: Ray's own
                        res = JobResult(i, jobs[i].key, JobState.ERROR, error=str(exc))
                    except ray.exceptions.RayError as exc:  # the worker, its node or the object died
                        if attempts[i] <= self.retries:
                            todo.appendleft(i)
                            if on_event:
                                on_event(i, JobState.RETRIED, None)
                            continue
                        res = JobResult(i, jobs[i].key, JobState.LOST,
                                        error=f"lost {attempts[i]} times: {type(exc).__name__}: {exc}")
                    res.attempts = attempts[i]
                    finish(jobs, res, results, on_event)
        except KeyboardInterrupt:
            for ref in flying:
                ray.cancel(ref, force=True)
        return fill(jobs, results, attempts, JobState.CANCELED)
