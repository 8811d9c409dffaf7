"""The executor contract: a sweep is a list of picklable `Job`s; an executor runs them and returns one
`JobResult` per job, in job order, whatever order they finished in.

A job runs on a worker in a private scratch folder; every file it writes there comes back as data
(`JobResult.files`) and the driver writes it under the job's `out_dir`, so no shared filesystem is needed and
local and remote runs produce the same bytes. The job's wall-clock limit is enforced on the worker itself
(`JobTimeout` is raised in the job's thread, so its own clean-up — stopping agent processes, closing the
simulation — runs there); the driver only retries runs whose worker died.
"""

from __future__ import annotations

import shutil
import signal
import tempfile
import threading
import time
import traceback
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import Path
from typing import Any, Protocol

JobFn = Callable[[Any, Path], Any]  # (payload, scratch folder) → a picklable value


class JobState(StrEnum):
    QUEUED = "queued"
    RUNNING = "running"
    RETRIED = "retried"  # a worker died under it; it is queued again (a count, not a final state)
    DONE = "done"  # the job function returned (its value may still say the run failed)
    ERROR = "error"  # the job function raised
    TIMEOUT = "timeout"  # the job's wall-clock limit fired on the worker
    LOST = "lost"  # its worker died more often than the retry budget allows
    CANCELED = "canceled"  # Ctrl-C on the driver before it finished

    @property
    def final(self) -> bool:
        return self not in (JobState.QUEUED, JobState.RUNNING, JobState.RETRIED)


@dataclass(frozen=True)
class Job:
    """One run. `fn` must be a module-level function (it is pickled by reference); `payload` is pickled by
    value. `out_dir` is where the driver writes the files the job produced. Resources are what a scheduler
    reserves for it: one CPU and a memory estimate (MB)."""

    key: str
    fn: JobFn
    payload: Any
    out_dir: str | None = None
    cpus: float = 1.0
    memory_mb: int = 500
    time_limit_s: float | None = None


@dataclass
class JobResult:
    index: int
    key: str
    state: JobState
    value: Any = None
    error: str = ""
    files: dict[str, bytes] = field(default_factory=dict)  # relative path → content (written on the driver)
    attempts: int = 1
    wall_s: float = 0.0  # on the worker, for the last attempt
    worker: str = ""  # host:pid that ran the last attempt


class JobTimeout(BaseException):  # BaseException: no `except Exception` in a job may swallow it
    pass


Events = Callable[[int, JobState, JobResult | None], None] | None  # (job index, new state, its result if final)


class Executor(Protocol):
    def run(self, jobs: list[Job], on_event: Events = None) -> list[JobResult]:
        """Run every job; `on_event` on the driver for each change of state. Ctrl-C returns what finished,
        the rest CANCELED."""
        ...


@contextmanager
def deadline(seconds: float | None) -> Iterator[None]:
    """Raise JobTimeout in this thread after `seconds` of wall time (SIGALRM: main thread only, which is where
    pool and Ray workers run their tasks; elsewhere there is no limit and the driver's own limit applies)."""
    if seconds is None or threading.current_thread() is not threading.main_thread():
        yield
        return

    def fire(signum: int, frame: Any) -> None:
        raise JobTimeout(f"the run exceeded its time limit of {seconds:g} s")

    old = signal.signal(signal.SIGALRM, fire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def run_job(index: int, job: Job) -> JobResult:
    """Worker side: run `job` in a scratch folder under its time limit, return its value and its files."""
    import os
    import socket

    from fleet.executors.isolation import reset_id_counters

    reset_id_counters()
    scratch = Path(tempfile.mkdtemp(prefix="fleetnav-job-"))
    t0 = time.perf_counter()
    res = JobResult(index, job.key, JobState.DONE, worker=f"{socket.gethostname()}:{os.getpid()}")
    try:
        with deadline(job.time_limit_s):
            res.value = job.fn(job.payload, scratch)
    except JobTimeout as exc:
        res.state, res.error = JobState.TIMEOUT, str(exc)
    except Exception as exc:  # a broken run is reported, never takes the sweep down
        res.state, res.error = JobState.ERROR, f"{type(exc).__name__}: {exc}\n{traceback.format_exc()}"
    finally:  # also on Ctrl-C in the inline executor: no scratch folder is left behind
        res.wall_s = time.perf_counter() - t0
        res.files = collect_files(scratch)
        shutil.rmtree(scratch, ignore_errors=True)
    return res


def collect_files(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def write_files(files: dict[str, bytes], out_dir: str | Path) -> None:
    """The driver's half of the file transfer: the job's files under `out_dir` (paths stay inside it)."""
    root = Path(out_dir)
    for rel, data in files.items():
        target = root / rel
        if ".." in Path(rel).parts or Path(rel).is_absolute():
            raise ValueError(f"a job returned a file outside its folder: {rel}")
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(data)
