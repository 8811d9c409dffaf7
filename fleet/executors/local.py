"""Local executors: `InlineExecutor` runs the jobs one after another in this process (`-j 1`);
`PoolExecutor` runs them in N worker processes of its own, so it knows which job each worker holds: a worker
that dies (killed, out of memory, a segfault in native code) costs that job one retry, not the sweep.
"""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import os
import signal
import time
from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from typing import Any

from fleet.executors.base import Events, Job, JobResult, JobState, run_job, write_files

GRACE_S = 30.0  # past a job's own limit, the driver kills a worker that did not come back


def finish(jobs: list[Job], res: JobResult, results: list[JobResult | None], on_event: Events) -> None:
    """Driver side of a returned job: its files under its out_dir, its result in place, one event."""
    job = jobs[res.index]
    if job.out_dir is not None:
        write_files(res.files, job.out_dir)
    results[res.index] = res
    if on_event:
        on_event(res.index, res.state, res)


def fill(jobs: list[Job], results: list[JobResult | None], attempts: list[int], state: JobState) -> list[JobResult]:
    """Every job without a result gets one in `state` (CANCELED after Ctrl-C)."""
    return [r if r is not None else JobResult(i, jobs[i].key, state, attempts=attempts[i], error=state.value)
            for i, r in enumerate(results)]


class InlineExecutor:
    """In this process, in job order. The job's time limit holds (SIGALRM); a crash of native code ends the
    sweep, so use the pool (`-j 2`) or Ray when runs may crash the interpreter."""

    def run(self, jobs: list[Job], on_event: Events = None) -> list[JobResult]:
        results: list[JobResult | None] = [None] * len(jobs)
        try:
            for i, job in enumerate(jobs):
                if on_event:
                    on_event(i, JobState.RUNNING, None)
                finish(jobs, run_job(i, job), results, on_event)
        except KeyboardInterrupt:
            pass
        return fill(jobs, results, [1] * len(jobs), JobState.CANCELED)


def _worker_main(conn: Connection) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C belongs to the driver, which then stops us
    while True:
        msg = conn.recv()
        if msg is None:
            return
        i, job = msg
        conn.send(run_job(i, job))


@dataclass
class _Worker:
    proc: Any
    conn: Connection
    job: int | None = None
    since: float = 0.0


class PoolExecutor:
    """`jobs` worker processes from a fork server (not fork: the driver may hold PyBullet clients and threads)
    that has imported `preload` once, so each worker starts without paying the imports again."""

    def __init__(self, jobs: int, retries: int = 2, preload: tuple[str, ...] = ()) -> None:
        self.n, self.retries, self.preload = jobs, retries, preload

    def run(self, jobs: list[Job], on_event: Events = None) -> list[JobResult]:
        ctx = mp.get_context("forkserver")
        if self.preload:
            ctx.set_forkserver_preload(list(self.preload))
        results: list[JobResult | None] = [None] * len(jobs)
        attempts = [0] * len(jobs)
        todo = deque(range(len(jobs)))
        pool: list[_Worker] = []

        def spawn() -> _Worker:
            here, there = ctx.Pipe()
            p = ctx.Process(target=_worker_main, args=(there,), daemon=True)
            p.start()
            there.close()
            return _Worker(p, here)

        def lost(w: _Worker, state: JobState, why: str) -> None:
            """The worker under job `w.job` died (or was killed for overrunning): retry or give up."""
            assert w.job is not None
            i, w.job = w.job, None
            if state is JobState.RETRIED and attempts[i] <= self.retries:
                todo.appendleft(i)
                if on_event:
                    on_event(i, JobState.RETRIED, None)
                return
            final = JobState.LOST if state is JobState.RETRIED else state
            finish(jobs, JobResult(i, jobs[i].key, final, error=why, attempts=attempts[i]), results, on_event)

        try:
            with one_thread_per_worker():
                pool = [spawn() for _ in range(min(self.n, len(jobs)))]
            while todo or any(w.job is not None for w in pool):
                for w in pool:
                    if w.job is None and todo:
                        w.job, w.since = todo.popleft(), time.monotonic()
                        attempts[w.job] += 1
                        w.conn.send((w.job, jobs[w.job]))
                        if on_event:
                            on_event(w.job, JobState.RUNNING, None)
                busy = [w for w in pool if w.job is not None]
                ready = set(wait([w.conn for w in busy] + [w.proc.sentinel for w in busy], timeout=0.2))
                for k, w in enumerate(pool):
                    if w.job is None:
                        continue
                    if w.conn in ready:
                        try:
                            res: JobResult = w.conn.recv()
                        except (EOFError, OSError):
                            res = None  # type: ignore[assignment]
                        if res is not None:
                            res.attempts = attempts[res.index]
                            w.job = None
                            finish(jobs, res, results, on_event)
                            continue
                    limit = jobs[w.job].time_limit_s
                    overrun = limit is not None and time.monotonic() - w.since > limit + GRACE_S
                    if w.proc.sentinel in ready or w.conn in ready or overrun:
                        code = _stop(w)
                        if overrun:
                            lost(w, JobState.TIMEOUT, f"the worker did not return within {limit:g} s + "
                                 f"{GRACE_S:g} s and was killed")
                        else:
                            lost(w, JobState.RETRIED, f"the worker died (exit code {code}) {attempts[w.job]} times")
                        pool[k] = spawn()
        except KeyboardInterrupt:
            pass
        finally:
            for w in pool:
                if w.job is None and w.proc.is_alive():
                    with contextlib.suppress(OSError):
                        w.conn.send(None)
                _stop(w, wait_s=0.0 if w.job is not None else 2.0)
        return fill(jobs, results, attempts, JobState.CANCELED)


@contextlib.contextmanager
def one_thread_per_worker() -> Iterator[None]:
    """Workers (and the fork server, started with the first) see OMP/OpenBLAS/MKL limited to one thread, as
    Ray does for a 1-CPU task: N workers × a BLAS thread per core would oversubscribe the cores they share."""
    saved = {k: os.environ.get(k) for k in THREAD_VARS}
    os.environ.update({k: "1" for k, v in saved.items() if v is None})
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)


THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def _stop(w: _Worker, wait_s: float = 0.0) -> int | None:
    w.proc.join(wait_s)
    if w.proc.is_alive():
        w.proc.kill()
        w.proc.join(5.0)
    w.conn.close()
    return int(w.proc.exitcode) if w.proc.exitcode is not None else None
