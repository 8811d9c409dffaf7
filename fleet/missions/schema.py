"""The mission file: nested pydantic models, `extra="forbid"` everywhere, events and assertions by `type:`.

A mission names a world, a seed and a time limit; spawns robots (one by one or as a formation); gives them
work (tasks per robot, tasks to allocate, swarm behaviours); scripts events (obstacles, sensor faults,
kills, e-stops); may launch external agents; and states what must hold (assertions). References between
sections (robot names, task keys) are checked by the loader, which points at the offending line.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal, Union

from pydantic import Field, field_validator, model_validator

from fleet.config import BatteryConfig
from fleet.missions.assertions import ASSERTIONS, AssertionBase
from fleet.missions.events import EVENTS, EventBase
from fleet.missions.types import PoseSpec
from fleet.safety import SafetyConfig
from sim.config import StrictModel
from slam.types import SlamConfig

NAME = r"^[A-Za-z][A-Za-z0-9_\-]*$"
Formation = Literal["line", "column", "grid", "circle", "wedge", "random"]

# Discriminated unions over the registries, so `type:` picks the model and a typo lists the valid types
# (type checkers see the common base class).
if TYPE_CHECKING:
    EventSpec = EventBase
    AssertionSpec = AssertionBase
else:
    EventSpec = Annotated[Union[EVENTS.models()], Field(discriminator="type")]  # noqa: UP007
    AssertionSpec = Annotated[Union[ASSERTIONS.models()], Field(discriminator="type")]  # noqa: UP007


class PhysicsSection(StrictModel):
    physics_hz: float = Field(100.0, ge=10, le=2000)
    control_hz: float = Field(10.0, ge=1, le=200)
    fidelity: Literal["kinematic", "dynamic"] = "kinematic"
    gravity: tuple[float, float, float] | None = None
    solver_iterations: int | None = Field(None, ge=1, le=1000)

    @model_validator(mode="after")
    def _rates(self) -> PhysicsSection:
        if self.control_hz > self.physics_hz:
            raise ValueError(f"control_hz {self.control_hz} exceeds physics_hz {self.physics_hz}")
        return self


class RobotEntry(StrictModel):
    name: str = Field(pattern=NAME)
    model: str = "diffbot"
    pose: PoseSpec | None = None
    spawn: str | None = Field(None, description="a spawn point of the world, instead of pose")
    fidelity: Literal["kinematic", "dynamic"] | None = None
    navigation: dict[str, Any] = Field(default_factory=dict, description="overrides for this robot's tasks")
    battery: float | None = Field(None, ge=0, le=1, description="initial state of charge")

    @model_validator(mode="after")
    def _where(self) -> RobotEntry:
        if (self.pose is None) == (self.spawn is None):
            raise ValueError("give exactly one of pose or spawn")
        return self


class FleetEntry(StrictModel):
    count: int = Field(ge=1, le=200)
    prefix: str = Field("robot", pattern=NAME)
    formation: Formation = "grid"
    centre: PoseSpec | None = None
    spacing: float = Field(1.5, gt=0)
    radius: float | None = Field(None, gt=0, description="random formation: sampling radius")
    model: str | None = None
    fidelity: Literal["kinematic", "dynamic"] | None = None


class TrafficSection(StrictModel):
    """The traffic layer (fleet/traffic): PIBT on a grid of the static map, executed asynchronously. Robots join
    it with `traffic_go` tasks (they must stand at traffic cell centres)."""

    type: Literal["pibt"] = "pibt"
    cell: float = Field(1.0, gt=0, description="grid cell side, m (≥ the footprint diameter + 0.1 m)")
    speed: float = Field(0.6, gt=0, description="peak speed along the cells, m/s")
    window: int = Field(1, ge=1, le=16, description="moves a robot may have planned ahead")
    stall_s: float = Field(10.0, gt=0, description="no progress for this long raises a deadlock event")
    priority: Literal["goal_age", "since_progress"] = Field(
        "goal_age", description="PIBT priority: time since the goal was given, or since the robot last got closer")
    lane_cost: float = Field(3.0, ge=1, le=100, description="cost factor of crossing a one-lane cell")
    highway: float = Field(4.0, ge=1, le=100, description="cost factor of a move against a row's/column's lane "
                           "direction (1: no lanes)")
    urgent_s: float | None = Field(10.0, gt=0, description="a robot not closer for this long outranks the rest "
                                   "until it is urgent_cells closer (null: off)")
    yield_aside: bool = Field(True, description="a pushed robot prefers a cell its pusher does not need next")
    urgent_rank: Literal["since_progress", "since_urgent"] = Field(
        "since_progress", description="order among urgent robots: longest without getting closer first, or first "
        "to become urgent first")
    congestion: float = Field(0.0, ge=0, le=100, description="toll per unit of a cell's recent occupancy in the "
                              "fields robots pick moves by (0: off; for fleets that saturate an aisle)")
    withdraw: Literal["off", "loops", "ahead", "both", "flush", "crowded"] = Field(
        "crowded", description="planned moves not yet started that are withdrawn: loops, moves ahead of an urgent "
        "robot, both, all every flush_s (a re-plan from the committed cells), or crowded (the default): all every "
        "flush_s while admission holds goals")
    flush_s: float = Field(1.0, gt=0, le=60, description="period of withdraw: flush, s")
    admission: Literal["off", "aimd", "park", "bound"] = Field(
        "bound", description="dispatch admission: new goals are held (FIFO, robot idle) while too many active robots "
        "are in a wait; the limit adapts (AIMD), none while the layer is not congested; park: as aimd, and held "
        "robots wait on parking cells off the main flow; bound (the default): held robots park, the limit is fixed at "
        "a tenth of the free cells, and a held goal whose way crosses the way of a robot in a wait stays held while "
        "that wait lasts")
    urgent_cells: int | None = Field(3, ge=1, description="urgency ends once a robot is this many cells closer than "
                                     "when it became urgent (null: at its goal)")
    urgent_window: int = Field(1, ge=1, le=16, description="moves an urgent robot may have planned ahead (1: "
                               "window; 2 shortens the 100-robot warehouse's long waits and lengthens the 300-robot "
                               "ones, docs/benchmarks-fleet.md)")
    keep_clear: bool = Field(True, description="a robot with a goal (or parking), not pushed, not urgent, enters "
                             "a crossing of aisles only with a way out towards its goal, or once it has waited "
                             "keep_clear_s at rest (do not block the box; shortens the warehouse's long waits at 100 "
                             "and 300 robots, docs/benchmarks-fleet.md)")
    keep_clear_s: float = Field(4.0, gt=0, le=60, description="a robot kept out of a crossing this long at rest "
                                "enters anyway, s")
    held_clear: bool = Field(True, description="with admission bound: a robot whose goal is held plans no move of "
                             "its own into the next cells of the way of a robot in a wait (it can still be pushed "
                             "there; fewer long waits on the 300-robot warehouse, docs/benchmarks-fleet.md)")
    hold_ground_s: float | None = Field(5.0, ge=0, le=600, description="a robot with a goal, not urgent, that has "
                                        "not come closer for this long is not pushed farther from its goal (its "
                                        "pusher tries another cell or waits) until it becomes urgent (null: off; "
                                        "needs urgent_s; "
                                        "fewer long waits on the 300-robot warehouse, docs/benchmarks-fleet.md)")
    one_way: bool = Field(True, description="one-lane corridors that are not dead ends are one-way, where the "
                          "graph stays strongly connected (no head-on meetings in them)")


class TaskEntry(StrictModel):
    id: str | None = Field(None, pattern=NAME, description="key for assertions (default: <type>_<index>)")
    robot: str
    type: str
    params: dict[str, Any] = Field(default_factory=dict)
    priority: int = 0
    at: float = Field(0.0, ge=0, description="sim time at which it is submitted")


class AllocTask(StrictModel):
    id: str = Field(pattern=NAME)
    type: str
    params: dict[str, Any] = Field(default_factory=dict)
    priority: int = 0
    earliest_start: float | None = None
    deadline: float | None = None


class AllocationSection(StrictModel):
    method: Literal["hungarian", "greedy", "auction"] = "hungarian"
    robots: list[str] | None = Field(None, description="default: every idle robot")
    at: float = Field(0.0, ge=0)
    options: dict[str, Any] = Field(default_factory=dict, description="AllocationOptions: cost, speed_factor, ...")
    tasks: list[AllocTask] = Field(min_length=1)


class BehaviourEntry(StrictModel):
    id: str | None = Field(None, pattern=NAME)
    type: str
    robots: list[str] | None = None
    params: dict[str, Any] = Field(default_factory=dict)
    at: float = Field(0.0, ge=0)


class AgentEntry(StrictModel):
    name: str = Field(pattern=NAME, description="its agent id (FLEETNAV_AGENT_ID)")
    command: list[str] = Field(min_length=1, description="argv; placeholders {connect} {world} {robots} {robot} "
                               "{agent_id} {lockstep} {mission_dir}, also given as FLEETNAV_* variables; 'python' "
                               "is the interpreter fleetnav runs in")
    robots: list[str] = Field(default_factory=list, description="the robots it drives (lock-step waits for them)")
    env: dict[str, str] = Field(default_factory=dict)
    required: bool = Field(True, description="the mission fails if the agent exits non-zero")


class AgentsSection(StrictModel):
    """Processes that connect over the Zenoh API; with them the world runs in service mode behind a bridge."""

    lockstep: bool = Field(True, description="the world waits for the agents every control tick (deterministic)")
    tick_timeout_s: float = Field(10.0, gt=0, le=600, description="wall s before a silent agent is declared hung")
    startup_timeout_s: float = Field(60.0, gt=0, le=3600, description="wall s for the agents to join")
    wall_limit_s: float = Field(1800.0, gt=0, description="wall s the whole run may take")
    exit_grace_s: float = Field(3.0, ge=0, le=60, description="wall s agents get to exit by themselves at the end")
    processes: list[AgentEntry] = Field(min_length=1)


class SlamEntry(StrictModel):
    robot: str
    config: SlamConfig = Field(default_factory=SlamConfig)


class RecordingSection(StrictModel):
    enabled: bool = True
    scans: bool = True
    markers_hz: float = Field(2.0, gt=0, le=50)
    camera_robot: str | None = Field(None, description="render this robot's camera into the recording")
    camera_hz: float = Field(1.0, gt=0, le=30)


class Mission(StrictModel):
    name: str = Field(pattern=NAME)
    description: str = ""
    world: str = Field(description="a world name in configs/worlds, or an SDF path relative to this file")
    seed: int = 0
    time_limit: float = Field(gt=0, le=36_000, description="sim seconds")
    end_when: Literal["tasks_done", "time_limit"] = Field(
        "tasks_done", description="tasks_done: stop once every task ended and no event or behaviour is pending")
    physics: PhysicsSection = Field(default_factory=PhysicsSection)
    navigation: dict[str, Any] = Field(default_factory=dict, description="planning.NavigatorConfig fields")
    avoidance: dict[str, Any] = Field(default_factory=lambda: {"type": "orca"})
    traffic: TrafficSection | None = Field(None, description="enable the traffic layer (traffic_go tasks)")
    safety: SafetyConfig = Field(default_factory=SafetyConfig)
    battery: BatteryConfig = Field(default_factory=BatteryConfig)
    costmap_resolution: float = Field(0.05, gt=0.005, le=1.0)
    robots: list[RobotEntry] = Field(default_factory=list)
    fleets: list[FleetEntry] = Field(default_factory=list)
    tasks: list[TaskEntry] = Field(default_factory=list)
    allocation: AllocationSection | None = None
    behaviours: list[BehaviourEntry] = Field(default_factory=list)
    events: list[EventSpec] = Field(default_factory=list)
    agents: AgentsSection | None = None
    slam: list[SlamEntry] = Field(default_factory=list)
    assertions: list[AssertionSpec] = Field(min_length=1)
    recording: RecordingSection = Field(default_factory=RecordingSection)

    @field_validator("navigation")
    @classmethod
    def _nav(cls, v: dict[str, Any]) -> dict[str, Any]:
        from planning.navigator import NavigatorConfig

        NavigatorConfig.model_validate(v)
        return v

    @model_validator(mode="after")
    def _someone(self) -> Mission:
        if not self.robots and not self.fleets:
            raise ValueError("a mission needs robots or fleets")
        return self

    # ---- derived -----------------------------------------------------------------------------------------

    def robot_names(self) -> list[str]:
        """Every robot, in spawn order: named robots, then each fleet's `<prefix><k>` (as spawn_fleet names them)."""
        names = [r.name for r in self.robots]
        for f in self.fleets:
            k, made = 1, 0
            while made < f.count:
                if f"{f.prefix}{k}" not in names:
                    names.append(f"{f.prefix}{k}")
                    made += 1
                k += 1
        return names

    def task_keys(self) -> list[str]:
        keys = [t.id or f"{t.type}_{i}" for i, t in enumerate(self.tasks)]
        return keys + ([t.id for t in self.allocation.tasks] if self.allocation else [])

    def behaviour_keys(self) -> list[str]:
        return [b.id or f"{b.type}_{i}" for i, b in enumerate(self.behaviours)]

    def assertion_names(self) -> list[str]:
        return [a.name or f"{a.type}_{i}" for i, a in enumerate(self.assertions)]


def json_schema() -> dict[str, Any]:
    """The JSON Schema of mission files, for editors (configs/missions/mission.schema.json)."""
    schema = Mission.model_json_schema()
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "fleetnav mission"
    return schema


def write_json_schema(path: str | Path) -> Path:
    p = Path(path)
    p.write_text(json.dumps(json_schema(), indent=2, sort_keys=True) + "\n", encoding="utf-8")
    return p
