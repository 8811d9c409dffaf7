"""The task manager: per-robot queues, the active task of each robot, lifecycle events, cancel."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from fleet.tasks.base import Command, Task, TaskContext, new_task_id, task_class
from fleet.types import TaskState
from sim.errors import ErrorCode, FleetError

if TYPE_CHECKING:
    from fleet.fleet_view import FleetView

HISTORY = 10_000


class TaskManager:
    """A ControlSource: each control tick the active task of each robot decides its command."""

    def __init__(self, view: FleetView) -> None:
        self.view = view
        self.tasks: dict[str, Task] = {}
        self.active: dict[str, Task] = {}  # robot → its running task
        self.queues: dict[str, list[Task]] = {}  # robot → waiting tasks, highest priority first

    # ---- submitting and querying ------------------------------------------------------------------------

    def submit(self, type_name: str, robot: str, params: dict[str, Any] | None = None, *, priority: int = 0,
               not_before: float | None = None) -> Task:
        """Queue a task for a robot (validated now, so bad input fails at once). With `not_before` the robot
        does not start it before that sim time (it waits where it is)."""
        self.view.robot_record(robot)
        cls = task_class(type_name)
        if not_before is not None and math.isnan(not_before):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, "not_before must be a sim time, got NaN")
        task = cls(id=new_task_id(), robot=robot, params=dict(params or {}), priority=priority,
                   created=self.view.time, not_before=-math.inf if not_before is None else not_before)
        task.validate(self.view)
        self.tasks[task.id] = task
        q = self.queues.setdefault(robot, [])
        q.append(task)
        q.sort(key=lambda t: -t.priority)  # stable: FIFO within a priority
        self._trim()
        return task

    def get(self, task_id: str) -> Task:
        if task_id not in self.tasks:
            recent = list(self.tasks)[-10:]
            raise FleetError(ErrorCode.NOT_FOUND, f"no task '{task_id}'",
                             f"recent tasks: {', '.join(recent) or 'none'}")
        return self.tasks[task_id]

    def cancel(self, task_id: str, reason: str = "canceled by request") -> Task:
        task = self.get(task_id)
        if task.state.done:
            return task
        self._end(task, TaskState.CANCELED, reason)
        return task

    # ---- ControlSource -----------------------------------------------------------------------------------

    def commands(self, now: float) -> dict[str, Command]:
        ctx = TaskContext(self.view, now)
        out: dict[str, Command] = {}
        for robot in list(self.queues):
            task = self.active.get(robot)
            if task is None:
                task = self._activate_next(robot, ctx)
                if task is None:
                    continue
            if self.view.estopped(robot):
                out[robot] = (0.0, 0.0)  # an e-stopped robot's task waits (its clock keeps running)
                continue
            try:
                cmd = task.step(ctx)
            except FleetError as exc:  # e.g. PLANNING_FAILED: the task fails with the reason, the world runs on
                cmd = task.fail(now, f"{exc.code.value}: {exc.message}")
            if task.state.done:
                self._end(task, task.state, task.reason)
            out[robot] = cmd
        return out

    def owner(self, robot: str) -> str | None:
        task = self.active.get(robot)
        return f"task:{task.id}" if task is not None else None

    def active_count(self) -> int:
        return len(self.active)

    def cancel_all(self, reason: str) -> None:
        for task in list(self.tasks.values()):
            if not task.state.done:
                self._end(task, TaskState.CANCELED, reason)

    def release(self, robot: str, reason: str) -> None:
        for task in [*self.queues.get(robot, [])]:
            self._end(task, TaskState.CANCELED, reason)
        if robot in self.active:
            self._end(self.active[robot], TaskState.CANCELED, reason)

    # ---- internals ---------------------------------------------------------------------------------------

    def _activate_next(self, robot: str, ctx: TaskContext) -> Task | None:
        q = self.queues.get(robot, [])
        if not q:
            self.queues.pop(robot, None)
            return None
        if q[0].not_before > ctx.now:  # its time window has not opened: the robot waits
            return None
        task = q.pop(0)
        task.state, task.started = TaskState.ACTIVE, ctx.now
        self.active[robot] = task
        self.view.publish(ctx.now, "task_started", (robot,), f"{task.type_name} {task.id} started",
                          task=task.id, type=task.type_name)
        try:
            task.begin(ctx)
        except FleetError as exc:
            task.fail(ctx.now, f"{exc.code.value}: {exc.message}")
            self._end(task, TaskState.FAILED, task.reason)
            return None
        return task

    def _end(self, task: Task, state: TaskState, reason: str) -> None:
        now = self.view.time
        if state is TaskState.CANCELED:
            task.cancel(reason)
        task.state, task.reason = state, reason
        task.finished = now
        if self.active.get(task.robot) is task:
            del self.active[task.robot]
        q = self.queues.get(task.robot)
        if q is not None and task in q:
            q.remove(task)
        kind = {TaskState.SUCCEEDED: "task_finished", TaskState.FAILED: "task_failed",
                TaskState.CANCELED: "task_canceled"}[state]
        self.view.publish(now, kind, (task.robot,), f"{task.type_name} {task.id} {state.value}"
                          + (f": {reason}" if reason else ""), task=task.id, type=task.type_name, reason=reason)

    def _trim(self) -> None:
        if len(self.tasks) > HISTORY:
            for tid in [t for t, task in self.tasks.items() if task.state.done][: len(self.tasks) - HISTORY]:
                del self.tasks[tid]
