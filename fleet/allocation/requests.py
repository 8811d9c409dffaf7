"""Turning what a caller asks for (task dicts) into TaskRequests: validated, with a work profile each."""

from __future__ import annotations

import itertools
import math
from typing import TYPE_CHECKING, Any

from pydantic import ValidationError

from fleet.allocation.types import TaskRequest, TaskSpec
from fleet.tasks.base import allocatable_types, task_class
from sim.errors import ErrorCode, FleetError

if TYPE_CHECKING:
    from fleet.fleet_view import FleetView

_ids = itertools.count(1)


def parse_spec(raw: dict[str, Any] | TaskSpec) -> TaskSpec:
    if isinstance(raw, TaskSpec):
        return raw
    try:
        return TaskSpec.model_validate(raw)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first["loc"]) or "task"
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"task {raw!r}: {where}: {first['msg']}",
                         "a task is {type, params, priority?, earliest_start?, deadline?, id?}") from exc


def make_request(spec: TaskSpec, view: FleetView) -> TaskRequest:
    """Check the type and params now (bad input fails before anything is planned) and profile the work."""
    cls = task_class(spec.type)
    if not cls.allocatable:  # robot-bound types (return_home, follow_robot, ...) have no robot-free profile
        raise FleetError(ErrorCode.UNSUPPORTED, f"task type '{spec.type}' cannot be allocated",
                         f"allocatable types: {', '.join(allocatable_types())}; submit it to a robot instead")
    for name, value in (("earliest_start", spec.earliest_start), ("deadline", spec.deadline)):
        if value is not None and math.isnan(value):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{name} must be a sim time in seconds, got NaN")
    profile = cls.work_profile(spec.params, view)
    return TaskRequest(id=spec.id or f"q{next(_ids)}", type=spec.type, params=dict(spec.params), profile=profile,
                       priority=spec.priority,
                       earliest_start=-math.inf if spec.earliest_start is None else spec.earliest_start,
                       deadline=math.inf if spec.deadline is None else spec.deadline)
