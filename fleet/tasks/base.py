"""Task plumbing: the Task base class, the per-tick context, and the task-type registry (`type:` key)."""

from __future__ import annotations

import itertools
import math
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar

from fleet.tasks.types import WorkProfile
from fleet.types import TaskState
from sim.errors import ErrorCode, FleetError, unknown_name
from sim.types import Pose2D

if TYPE_CHECKING:
    from fleet.fleet_view import FleetView

Command = tuple[float, float]
_ids = itertools.count(1)


def new_task_id() -> str:
    return f"t{next(_ids)}"


@dataclass
class TaskContext:
    view: FleetView
    now: float

    def pose(self, robot: str) -> Pose2D:
        return self.view.robots.pose_of(robot)

    def twist(self, robot: str) -> tuple[float, float]:
        return self.view.robots.twist_of(robot)


@dataclass
class Task(ABC):
    """A unit of work for one robot. Subclasses implement `begin` and `step`; both run on the sim thread.

    `step` returns the (v, ω) to apply, and ends the task with `self.succeed()`, `self.fail(reason)`."""

    type_name: ClassVar[str] = ""
    allocatable: ClassVar[bool] = False  # True where work_profile is implemented
    id: str
    robot: str
    params: dict[str, Any]
    priority: int = 0
    state: TaskState = TaskState.QUEUED
    reason: str = ""
    created: float = 0.0
    started: float = math.nan
    finished: float = math.nan
    progress: dict[str, Any] = field(default_factory=dict)
    not_before: float = -math.inf  # sim time before which the manager does not start it (a time window)

    def validate(self, view: FleetView) -> None:  # noqa: B027 - an optional hook, not abstract
        """Check params when submitted, so bad input fails at once (override per type)."""

    def begin(self, ctx: TaskContext) -> None:  # noqa: B027 - an optional hook, not abstract
        """Called once when the task becomes active."""

    @abstractmethod
    def step(self, ctx: TaskContext) -> Command:
        """One control tick of the task: the (v, ω) to apply."""

    def cancel(self, reason: str) -> None:  # noqa: B027 - an optional hook, not abstract
        """Stop whatever the task drives; the manager marks it canceled."""

    @classmethod
    def work_profile(cls, params: dict[str, Any], view: FleetView) -> WorkProfile:
        """Where the task starts and ends and how much work it is, for the allocator (override per type)."""
        raise FleetError(ErrorCode.UNSUPPORTED, f"task type '{cls.type_name}' cannot be allocated",
                         f"allocatable types: {', '.join(allocatable_types())}; submit it to a robot instead")

    def succeed(self, now: float) -> Command:
        self.state, self.finished = TaskState.SUCCEEDED, now
        return (0.0, 0.0)

    def fail(self, now: float, reason: str) -> Command:
        self.state, self.finished, self.reason = TaskState.FAILED, now, reason
        return (0.0, 0.0)

    def to_dict(self) -> dict[str, Any]:
        return {"id": self.id, "type": self.type_name, "robot": self.robot, "state": self.state.value,
                "reason": self.reason, "priority": self.priority, "params": _jsonable(self.params),
                "created": self.created, "started": None if math.isnan(self.started) else self.started,
                "finished": None if math.isnan(self.finished) else self.finished,
                "progress": _jsonable(self.progress),
                **({"not_before": self.not_before} if math.isfinite(self.not_before) else {})}


def _jsonable(v: Any) -> Any:
    if isinstance(v, dict):
        return {k: _jsonable(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [_jsonable(x) for x in v]
    if isinstance(v, Pose2D):
        return {"x": v.x, "y": v.y, "yaw": v.yaw}
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if hasattr(v, "tolist"):
        return v.tolist()
    return v


TaskFactory = Callable[..., Task]
_REGISTRY: dict[str, type[Task]] = {}


def register_task(cls: type[Task]) -> type[Task]:
    """Class decorator: register a task type under `cls.type_name`. Registering a name twice raises."""
    name = cls.type_name
    if not name:
        raise ValueError(f"{cls.__name__} has no type_name")
    if name in _REGISTRY:
        raise ValueError(f"task type '{name}' is already registered")
    if getattr(cls.step, "__isabstractmethod__", False):
        raise TypeError(f"{cls.__name__} must implement step()")
    _REGISTRY[name] = cls
    return cls


def task_class(name: str) -> type[Task]:
    if name not in _REGISTRY:
        raise unknown_name("task type", name, list(_REGISTRY), ErrorCode.INVALID_ARGUMENT)
    return _REGISTRY[name]


def task_types() -> list[str]:
    return sorted(_REGISTRY)


def allocatable_types() -> list[str]:
    """Task types with a work profile, i.e. that the allocator can give to any robot."""
    return sorted(n for n, c in _REGISTRY.items() if c.allocatable)


def pose_param(params: dict[str, Any], key: str = "goal") -> Pose2D:
    raw = params.get(key)
    if isinstance(raw, Pose2D):
        return raw
    if isinstance(raw, dict) and {"x", "y"} <= set(raw):
        return Pose2D(float(raw["x"]), float(raw["y"]), float(raw.get("yaw", 0.0)))
    if isinstance(raw, list | tuple) and len(raw) in (2, 3):
        return Pose2D(*(float(v) for v in raw))
    raise FleetError(ErrorCode.INVALID_ARGUMENT, f"parameter '{key}' must be a pose {{x, y, yaw}}, got {raw!r}")
