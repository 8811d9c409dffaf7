"""`run_map(fn, items)`: the shortest way to put a front door's loop on an executor. `fn(item) → value` is any
picklable module-level function of one item (it writes no files; use `Job` directly for runs that do)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from fleet.executors.base import Job, JobResult, JobState
from fleet.executors.progress import SweepProgress


def call_one(payload: tuple[Callable[[Any], Any], Any], scratch: Path) -> Any:
    fn, item = payload
    return fn(item)


def run_map(fn: Callable[[Any], Any], items: Sequence[Any], *, executor: str = "local", jobs: int | None = None,
            ray_address: str | None = None, retries: int = 2, time_limit_s: float | None = None,
            memory_mb: int = 500, label: str = "runs", key: Callable[[Any], str] = str, show_progress: bool = True,
            on_result: Callable[[JobResult], None] | None = None) -> list[JobResult]:
    """One JobResult per item, in item order (`.value` when `.state is JobState.DONE`); `on_result` on the
    driver as each one finishes (completion order)."""
    from fleet.executors import make_executor

    ex = make_executor(executor, jobs=jobs, ray_address=ray_address, retries=retries)
    work = [Job(key(it), call_one, (fn, it), memory_mb=memory_mb, time_limit_s=time_limit_s) for it in items]
    with SweepProgress(len(work), label=label, show=show_progress) as bar:
        def event(i: int, state: JobState, res: JobResult | None) -> None:
            bar.event(i, state, res)
            if res is not None and on_result is not None:
                on_result(res)

        return ex.run(work, on_event=event)
