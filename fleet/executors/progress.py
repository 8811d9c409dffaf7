"""One live progress bar for a whole sweep with per-state counts, and a summary table at the end."""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from types import TracebackType

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from fleet.executors.base import JobResult, JobState

Verdict = Callable[[JobResult], str]  # a finished job → the word counted for it ("pass", "fail", "error", ...)


def job_verdict(res: JobResult) -> str:
    return res.state.value


class SweepProgress:
    """Use as a context manager and pass `event` as the executor's `on_event`."""

    def __init__(self, total: int, *, label: str = "runs", verdict: Verdict = job_verdict, show: bool = True,
                 console: Console | None = None) -> None:
        self.total, self.verdict = total, verdict
        self.running: set[int] = set()
        self.counts: Counter[str] = Counter()
        self.retried = 0
        self.bar = Progress(TextColumn(label), BarColumn(), MofNCompleteColumn(), TextColumn("{task.fields[counts]}"),
                            TimeElapsedColumn(), disable=not show, console=console)
        self.task = self.bar.add_task(label, total=total, counts=self._counts())

    def __enter__(self) -> SweepProgress:
        self.bar.start()
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        self.bar.stop()

    def event(self, index: int, state: JobState, res: JobResult | None) -> None:
        if state is JobState.RUNNING:
            self.running.add(index)
        elif state is JobState.RETRIED:
            self.running.discard(index)
            self.retried += 1
        elif res is not None:
            self.running.discard(index)
            self.counts[self.verdict(res)] += 1
        done = sum(self.counts.values())
        self.bar.update(self.task, completed=done, counts=self._counts())

    def _counts(self) -> str:
        queued = self.total - sum(self.counts.values()) - len(self.running)
        parts = [f"queued {queued}", f"running {len(self.running)}"]
        parts += [f"{k} {v}" for k, v in sorted(self.counts.items())]
        return " · ".join(parts + ([f"retried {self.retried}"] if self.retried else []))


def summary_table(results: list[JobResult], verdict: Verdict = job_verdict, title: str = "sweep") -> Table:
    """Per verdict: runs, retried attempts, worker wall time (mean, max), and the first few keys."""
    t = Table(title=title)
    for col in ("result", "runs", "retries", "mean wall s", "max wall s", "runs (first 3)"):
        t.add_column(col, justify="left" if col in ("result", "runs (first 3)") else "right")
    groups: dict[str, list[JobResult]] = {}
    for r in results:
        groups.setdefault(verdict(r), []).append(r)
    for name, rs in sorted(groups.items()):
        walls = [r.wall_s for r in rs]
        t.add_row(name, str(len(rs)), str(sum(r.attempts - 1 for r in rs)), f"{sum(walls) / len(walls):.2f}",
                  f"{max(walls):.2f}", ", ".join(r.key for r in rs[:3]) + (" …" if len(rs) > 3 else ""))
    return t
