"""Typed parameters of every task type: one pydantic model per `type:` (unknown keys forbidden, every number
finite and bounded), the one place every front door's task params are checked (MCP `queue_task`/`assign_tasks`
and the task tools, Zenoh `navigate`, missions, Python `submit_task`).

`check(type, params, bounds)` validates against the type's model, then applies the checks that need the world
(poses inside its bounds + margin, simple polygons, a bounded coverage plan) and returns the params as the
task reads them: the given keys only (defaults stay the task's), numbers coerced. An unknown type or key is
an INVALID_ARGUMENT naming the valid ones. `allocatable_union()` is the discriminated union the MCP task
specs advertise. Limits are in docs/limits.md, next to fleet/validation.py's.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, is_dataclass
from typing import Annotated, Any, Literal, TypeVar

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    RootModel,
    ValidationError,
    WithJsonSchema,
    model_validator,
)
from pydantic.json_schema import SkipJsonSchema

from fleet import validation
from fleet.validation import Coord, Yaw
from sim.errors import ErrorCode, FleetError, unknown_name

MAX_TASK_S = 86_400.0  # wait, follow and sync durations: one sim day
MAX_ROUNDS = 1_000  # loop/patrol rounds
MAX_DWELL_S = 3_600.0
MAX_HOLES = 50
MAX_OVERLAP = 0.9  # coverage passes overlap; 1.0 would never end
MAX_FOLLOW_M = 100.0
NAME = Annotated[str, Field(min_length=1, max_length=64)]
Seconds = Annotated[float, Field(gt=0, le=MAX_TASK_S, allow_inf_nan=False)]


def _pose_in(v: Any) -> Any:
    """A Pose2D (Python callers) or [x, y(, yaw)] is read as {x, y(, yaw)}: one object form in the schema."""
    if is_dataclass(v) and not isinstance(v, type):
        return asdict(v)
    if isinstance(v, list | tuple) and len(v) in (2, 3):
        return dict(zip(("x", "y", "yaw"), v, strict=False))
    return v


def _tidy(schema: dict[str, Any]) -> None:
    """Keep the schema an assistant reads short: an optional field says what omitting it means, not `null`."""
    for prop in schema.get("properties", {}).values():
        if prop.get("default", 0) is None:
            del prop["default"]


class Model(BaseModel):
    model_config = ConfigDict(extra="forbid", json_schema_extra=_tidy)


T = TypeVar("T")
Opt = Annotated[T | SkipJsonSchema[None], "optional: null or omitted"]


class PoseIn(Model):
    x: Coord = Field(description="m")
    y: Coord = Field(description="m")
    yaw: Yaw = Field(0.0, description="rad")


Pose = Annotated[PoseIn, BeforeValidator(_pose_in)]


class NavOverrides(RootModel[dict[str, Any]]):
    """Partial navigator settings: checked against NavigatorConfig now, merged with the fleet's at start."""

    @model_validator(mode="after")
    def _known(self) -> NavOverrides:
        from planning.navigator import NavigatorConfig

        NavigatorConfig.model_validate(self.root)  # unknown keys and bad values fail here
        return self

    @classmethod
    def __get_pydantic_json_schema__(cls, core: Any, handler: Any) -> dict[str, Any]:
        from planning.navigator import NavigatorConfig

        return {"type": "object", "description": "navigator overrides for this task (navigation config keys)",
                "propertyNames": {"enum": list(NavigatorConfig.model_fields)}}


# Polygon rings: validated as validation.Polygon, advertised without repeating each vertex's bounds twice.
Ring = Annotated[validation.Polygon, WithJsonSchema({
    "type": "array", "minItems": 3, "maxItems": validation.MAX_POLYGON_VERTICES, "items": {
        "type": "array", "minItems": 2, "maxItems": 2, "items": {"type": "number", "minimum": -validation.MAX_COORD_M,
                                                                 "maximum": validation.MAX_COORD_M}}})]


class TaskParams(Model):
    """Every type takes `navigation` (missions add the robot's navigator settings to each of its tasks)."""

    navigation: Opt[NavOverrides] = Field(None, description="planner, controller, tolerances ...")


class WaitParams(TaskParams):
    seconds: float = Field(ge=0, le=MAX_TASK_S, allow_inf_nan=False, description="sim seconds to stand still")


class StopParams(TaskParams):
    pass


class GoToParams(TaskParams):
    goal: Pose = Field(description="{x, y, yaw} or [x, y(, yaw)]")
    align_yaw: bool = Field(False, description="also turn to the goal's yaw")


class ReturnHomeParams(TaskParams):
    align_yaw: bool = Field(True, description="turn to the home heading")


class DockAndChargeParams(TaskParams):
    dock: Opt[NAME] = Field(None, description="dock name; omitted: the nearest free one")
    target_soc: float = Field(0.9, gt=0, le=1, description="charge to reach, 0..1")


class FollowRobotParams(TaskParams):
    target: NAME = Field(description="the robot to follow")
    distance: float = Field(1.0, gt=0, le=MAX_FOLLOW_M, description="m behind it")
    regoal_distance: float = Field(0.3, gt=0, le=MAX_FOLLOW_M, description="m the follow point moves before "
                                   "re-planning")
    duration: Opt[Seconds] = Field(None, description="s; omitted: until canceled")


class CoverAreaParams(TaskParams):
    polygon: Ring = Field(description="outline [[x, y], ...], 3-200 vertices")
    holes: list[Ring] = Field(default_factory=list, max_length=MAX_HOLES, description="rings to "
                                            "leave out")
    tool_width: float = Field(0.5, ge=validation.MIN_TOOL_WIDTH_M, le=10, description="m")
    overlap: float = Field(0.1, ge=0, le=MAX_OVERLAP, description="fraction passes overlap")
    pattern: Literal["boustrophedon", "spiral"] = "boustrophedon"
    angle: Opt[Yaw] = Field(None, description="lane heading, rad; omitted: the best")
    min_coverage_pct: float = Field(0.0, ge=0, le=100, description="fail below this measured coverage")


class WaypointIn(Model):
    x: Coord = Field(description="m")
    y: Coord = Field(description="m")
    yaw: Yaw = Field(0.0, description="rad (with use_yaw)")
    dwell_s: Opt[Annotated[float, Field(ge=0, le=MAX_DWELL_S)]] = Field(None, description="s here; omitted: the "
                                                                         "task's")
    use_yaw: bool = Field(False, description="turn to yaw here")


Waypoint = Annotated[WaypointIn, BeforeValidator(_pose_in)]


class FollowWaypointsParams(TaskParams):
    waypoints: list[Waypoint] = Field(min_length=1, max_length=validation.MAX_WAYPOINTS,
                                      description="{x, y, yaw?, dwell_s?, use_yaw?} or [x, y(, yaw)]")
    mode: Literal["sequence", "loop", "patrol"] = "sequence"
    rounds: int | None = Field(1, ge=1, le=MAX_ROUNDS, description="loop/patrol rounds; null: until canceled")
    dwell_s: float = Field(0.0, ge=0, le=MAX_DWELL_S, description="default dwell at each waypoint, s")
    skip_failed: bool = Field(False, description="move on past an unreachable waypoint")


class SyncParams(TaskParams):
    barrier: NAME = Field(description="a barrier made by fleet_command sync")
    timeout_s: Opt[Seconds] = Field(None, description="s; omitted: wait forever")


class TrafficGoParams(TaskParams):
    """The layer's settings are fleet-wide: the mission's `traffic:` key or fleet.traffic.enable_traffic; a first
    traffic_go task with no layer enables one with the defaults."""

    goal: Pose = Field(description="{x, y} or [x, y]")


PARAMS: dict[str, type[TaskParams]] = {
    "wait": WaitParams, "stop": StopParams, "go_to": GoToParams, "return_home": ReturnHomeParams,
    "dock_and_charge": DockAndChargeParams, "follow_robot": FollowRobotParams, "cover_area": CoverAreaParams,
    "follow_waypoints": FollowWaypointsParams, "sync": SyncParams, "traffic_go": TrafficGoParams}


def model_of(type_name: str) -> type[TaskParams] | None:
    """The params model of a task type; None for a type registered without one (a plugin's)."""
    from fleet.tasks.base import task_class

    task_class(type_name)  # unknown type → INVALID_ARGUMENT listing the registered ones
    return PARAMS.get(type_name)


def check(type_name: Any, params: Any, bounds: validation.Bounds | None = None,
          where: str = "params") -> dict[str, Any]:
    """Validate a task's params for its type (see the module doc); returns what the task should get."""
    from fleet.tasks.base import task_types

    if not isinstance(type_name, str):
        raise unknown_name("task type", str(type_name), task_types(), ErrorCode.INVALID_ARGUMENT)
    if params is None:
        params = {}
    if not isinstance(params, Mapping):
        raise validation.bad(where, f"expected an object of {type_name} parameters, got {type(params).__name__}")
    kind = model_of(type_name)
    if kind is None:  # a plugin type without a model: the generic walk (finite, bounded, inside the world)
        if bounds is not None:
            validation.params(where, params, bounds)
        return dict(params)
    try:
        m = kind.model_validate(params)
    except ValidationError as exc:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{type_name} {where}: {validation.summarize(exc)}",
                         f"{type_name} takes: {', '.join(kind.model_fields)}") from None
    if bounds is not None:
        _in_world(m, bounds, f"{type_name} {where}")
    return m.model_dump(exclude_unset=True)


def _in_world(m: TaskParams, bounds: validation.Bounds, where: str) -> None:
    if isinstance(m, GoToParams):
        _point(f"{where}.goal", m.goal, bounds)
    elif isinstance(m, FollowWaypointsParams):
        for i, w in enumerate(m.waypoints):
            _point(f"{where}.waypoints[{i}]", w, bounds)
    elif isinstance(m, CoverAreaParams):
        outline = validation.polygon(f"{where}.polygon", m.polygon, bounds)
        for i, h in enumerate(m.holes):
            validation.polygon(f"{where}.holes[{i}]", h, bounds)
        validation.coverage(outline, m.tool_width, m.overlap)  # overlap 0.9 makes ten times the lanes


def _point(field: str, p: PoseIn | WaypointIn, bounds: validation.Bounds) -> None:
    validation.xy(field, p.x, p.y, bounds)


def allocatable_union() -> Any:
    """The task specs an allocator takes: one alternative per allocatable type, told apart by `type` (pydantic's
    discriminated union validates), advertised compactly (the common fields once, see `_SpecSchema`)."""
    from typing import Union

    from fleet.tasks.base import allocatable_types

    types = [t for t in allocatable_types() if t in PARAMS]
    alts = tuple(spec_model(t) for t in types)
    return Annotated[Union[alts], Field(discriminator="type"), _SpecSchema(types)]  # noqa: UP007 - a runtime tuple


class SpecCommon(Model):
    """The fields every task spec has besides `type` and `params`."""

    priority: int = Field(0, ge=-1000, le=1000, description="higher goes first when robots are scarce")
    earliest_start: Opt[Annotated[float, Field(ge=0, allow_inf_nan=False)]] = Field(
        None, description="sim time (s) before which it may not start")
    deadline: Opt[Annotated[float, Field(ge=0, allow_inf_nan=False)]] = Field(
        None, description="sim time (s) by which it should be done")
    id: Opt[Annotated[str, Field(min_length=1, max_length=64)]] = Field(None, description="your id (default: "
                                                                         "assigned)")


class _SpecSchema:
    """JSON schema of the spec union: one object with the common fields, `type` an enum, and a `oneOf` whose
    branches pin `type` and give that type's params model (a $def each). Pydantic would repeat the common
    fields in every branch; this says the same in about half the tokens."""

    def __init__(self, types: list[str]) -> None:
        self.types = types

    def __get_pydantic_json_schema__(self, core: Any, handler: Any) -> dict[str, Any]:
        common = handler.resolve_ref_schema(handler(SpecCommon.__pydantic_core_schema__))
        branches = [{"properties": {"type": {"const": t}, "params": handler(PARAMS[t].__pydantic_core_schema__)}}
                    for t in self.types]
        return {"type": "object", "additionalProperties": False, "required": ["type", "params"],
                "properties": {"type": {"enum": self.types, "description": "task type"},
                               "params": {"type": "object", "description": "that type's parameters"},
                               **common["properties"]},
                "oneOf": branches, "discriminator": {"propertyName": "type"}}


_SPECS: dict[str, type[BaseModel]] = {}


def spec_model(type_name: str) -> type[BaseModel]:
    """`{type: <type_name>, params: <its model>, priority, earliest_start, deadline, id}` as one model."""
    from pydantic import create_model

    if type_name not in _SPECS:
        _SPECS[type_name] = create_model(
            f"{PARAMS[type_name].__name__.removesuffix('Params')}Task", __base__=SpecCommon,
            type=(Literal[type_name], Field(description="task type")),  # type: ignore[arg-type]
            params=(PARAMS[type_name], Field(description=f"{type_name} parameters")))
    return _SPECS[type_name]
