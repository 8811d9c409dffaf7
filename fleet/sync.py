"""The `sync` task: a barrier. Each robot of a group finishes the work queued before it, then waits until
every robot of the group has reached the barrier (so all wait for the slowest); then all go on together."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from fleet.tasks.base import Command, Task, TaskContext, register_task
from fleet.types import TaskState
from sim.errors import ErrorCode, FleetError

if TYPE_CHECKING:
    from fleet.fleet_view import FleetView

_ids = itertools.count(1)


@dataclass
class Barrier:
    id: str
    robots: tuple[str, ...]
    tasks: dict[str, str] = field(default_factory=dict)  # robot → its sync task id
    released_at: float | None = None

    @staticmethod
    def new(robots: tuple[str, ...]) -> Barrier:
        return Barrier(f"sync{next(_ids)}", robots)

    def waiting_for(self, view: FleetView) -> list[str]:
        """Robots whose sync task is still queued behind other work (an ended task no longer holds anyone)."""
        return [r for r, tid in self.tasks.items() if view.task_state(tid) is TaskState.QUEUED]


@register_task
@dataclass(eq=False)
class SyncTask(Task):
    """Wait at barrier `barrier` until the whole group is there (optional `timeout_s`)."""

    type_name = "sync"

    def validate(self, view: FleetView) -> None:
        bid = self.params.get("barrier")
        if bid not in view.barriers:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"unknown barrier {bid!r}",
                             "use fleet_command('sync', robots) to create one")
        t = self.params.get("timeout_s")
        if t is not None and not (isinstance(t, int | float) and 0 < t < math.inf):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"timeout_s must be > 0, got {t!r}")

    def step(self, ctx: TaskContext) -> Command:
        barrier: Barrier = ctx.view.barriers[self.params["barrier"]]
        missing = barrier.waiting_for(ctx.view)
        self.progress = {"barrier": barrier.id, "waiting_for": missing}
        if not missing:  # the robots that checked earlier in this tick go on at the next one
            barrier.released_at = barrier.released_at if barrier.released_at is not None else ctx.now
            self.progress["released_at"] = barrier.released_at
            return self.succeed(ctx.now)
        timeout = self.params.get("timeout_s")
        if timeout is not None and ctx.now - self.started > float(timeout):
            return self.fail(ctx.now, f"timed out waiting for {', '.join(missing)}")
        return (0.0, 0.0)
