"""A challenge's runs as executor jobs (fleet.executors): each run is one job that resolves the challenge
again on its worker (a generated arena is regenerated from its seed), runs in the worker's scratch folder (the
agent's log comes back as data) and returns its RunResult. Used by `run_challenge(..., executor=...)`."""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from fleet.executors import Executor, Job, JobResult, JobState, SweepProgress
from fleet.grading.challenge import Challenge, resolve
from fleet.grading.types import RunResult

BASE_MB = 500  # one run: the interpreter, PyBullet, the planners and (for agents) a Zenoh bridge


@dataclass(frozen=True)
class ChallengeRun:
    challenge: Challenge
    k: int
    contestant: str
    optimal_length: float
    cwd: str  # the driver's working directory: an agent command like "python my_nav.py" is relative to it


def challenge_job(run: ChallengeRun, scratch: Path) -> RunResult:
    from fleet.grading.runner import _run_once
    from fleet.paths import robot_file
    from planning import FclWorld
    from sim.robot_spec import load_robot_spec

    with tempfile.TemporaryDirectory(prefix="fleetnav-challenge-") as work, _in(run.cwd):
        rc = resolve(run.challenge, work)
        spec = load_robot_spec(robot_file(run.challenge.robot))
        return _run_once(rc, run.k, run.contestant, spec, run.optimal_length, FclWorld(rc.description), scratch)


@contextlib.contextmanager
def _in(path: str):  # type: ignore[no-untyped-def]
    old = os.getcwd()
    if Path(path).is_dir():
        os.chdir(path)
    try:
        yield
    finally:
        os.chdir(old)


def run_all(ch: Challenge, contestant: str, runs: int, optimal_length: float, out: Path, executor: Executor,
            progress: Callable[[RunResult], None] | None = None, run_timeout: float | None = None,
            show_progress: bool = False) -> list[RunResult]:
    """Every run through `executor`; results in run order. A run whose job failed (an error, its time limit, a
    worker that kept dying) raises, since a challenge report needs every run; Ctrl-C returns the finished ones."""
    limit = run_timeout if run_timeout is not None else ch.agent.wall_limit_s + ch.time_limit + 120.0
    jobs = [Job(f"{ch.name} run {k}", challenge_job, ChallengeRun(ch, k, contestant, optimal_length, os.getcwd()),
                str(out), memory_mb=BASE_MB, time_limit_s=limit) for k in range(runs)]

    def verdict(r: JobResult) -> str:
        return r.value.outcome.value if r.state is JobState.DONE else r.state.value

    with SweepProgress(len(jobs), label="runs", verdict=verdict, show=show_progress) as bar:
        def event(i: int, state: JobState, res: JobResult | None) -> None:
            bar.event(i, state, res)
            if progress is not None and res is not None and res.state is JobState.DONE:
                progress(res.value)

        results = executor.run(jobs, on_event=event)
    bad = [r for r in results if r.state not in (JobState.DONE, JobState.CANCELED)]
    if bad:
        from sim.errors import ErrorCode, FleetError

        raise FleetError(ErrorCode.INTERNAL, f"{bad[0].key}: {bad[0].state.value}: {bad[0].error.splitlines()[0]}",
                         "see the error above; --retries and --run-timeout bound the retries and the wall time")
    return [r.value for r in results if r.state is JobState.DONE]
