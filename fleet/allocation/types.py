"""Types of task allocation: requests, options, the problem in arrays, and the result with paths and ETAs."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from pydantic import Field

from fleet.tasks.types import WorkProfile
from sim.config import StrictModel

Method = Literal["hungarian", "hungarian_rounds", "auction", "greedy"]
CostModel = Literal["path", "euclidean"]
METHODS: tuple[str, ...] = ("hungarian", "hungarian_rounds", "auction", "greedy")


class TaskSpec(StrictModel):
    """One queued task as a caller gives it: a task type and its params, plus allocation constraints."""

    type: str
    params: dict[str, Any] = Field(default_factory=dict)
    priority: int = 0
    earliest_start: float | None = Field(None, description="sim time before which the task may not start")
    deadline: float | None = Field(None, description="sim time by which it must be finished")
    id: str | None = None


class AllocationOptions(StrictModel):
    method: Method = "hungarian"
    cost: CostModel = Field("path", description="path: grid shortest paths around obstacles; euclidean: "
                                                "straight lines (fast, optimistic)")
    grid_resolution: float = Field(0.2, gt=0.01, le=2.0, description="m, of the grid the path costs use")
    speed_factor: float = Field(0.7, gt=0, le=1, description="ETA speed as a fraction of each robot's max_linear")
    reserve: float | None = Field(None, ge=0, lt=1, description="lowest charge a task may leave; default: the "
                                                                "battery low_threshold")
    charge_to: float = Field(0.9, gt=0, le=1, description="charge target of an inserted dock_and_charge")


@dataclass(frozen=True, slots=True)
class TaskRequest:
    id: str
    type: str
    params: dict[str, Any]
    profile: WorkProfile
    priority: int = 0
    earliest_start: float = -math.inf
    deadline: float = math.inf


@dataclass(frozen=True, slots=True)
class Energy:
    """Battery figures the allocator plans with (fleet BatteryConfig plus the allocation options)."""

    capacity_wh: float
    drive_wh_per_m: float
    idle_w: float
    charge_w: float
    reserve: float
    charge_to: float


@dataclass
class Problem:
    """Everything a solver needs, as arrays. Locations index rows/columns of `dist` (metres)."""

    now: float
    robots: list[str]
    robot_loc: np.ndarray  # (R,) location index of each robot
    soc: np.ndarray  # (R,) state of charge 0..1
    speed: np.ndarray  # (R,) planning speed, m/s
    tasks: list[TaskRequest]
    start_loc: np.ndarray  # (T,)
    end_loc: np.ndarray  # (T,)
    work_len: np.ndarray  # (T,) m
    work_time: np.ndarray  # (T,) s
    priority: np.ndarray  # (T,)
    earliest: np.ndarray  # (T,)
    deadline: np.ndarray  # (T,)
    docks: list[str]
    dock_loc: np.ndarray  # (K,)
    dist: np.ndarray  # (P, P) travel distance between locations (inf: unreachable)
    energy: Energy


@dataclass(frozen=True, slots=True)
class Step:
    """One task in a robot's plan, as the solver chose it."""

    task: int  # index into Problem.tasks
    dock: int  # index into Problem.docks of a charge stop before it, or -1
    travel: float  # m from the previous location (through the dock, if any) to the task's start
    begin: float  # sim time the task starts: drives off to it (after any charge, not before earliest_start)
    finish: float  # sim time it ends
    soc_after: float
    charge_s: float  # time spent charging before it


Plan = dict[int, list[Step]]  # robot index → its steps in order


@dataclass
class Assignment:
    request: str
    type: str
    robot: str
    order: int  # position in the robot's plan
    priority: int
    charge_dock: str | None  # a dock_and_charge is inserted before the task
    travel_m: float  # approach: from the previous location (through the dock) to the task's start
    work_m: float
    begin: float  # when the task starts (the robot sets off for it), sim time
    finish: float  # ETA of its end
    soc_after: float
    charge_s: float
    path: np.ndarray  # (N, 2) simplified polyline: approach then the work itself
    task_ids: list[str] = field(default_factory=list)  # ids of the submitted tasks (charge first), once run

    def to_dict(self, now: float) -> dict[str, Any]:
        return {"request": self.request, "type": self.type, "robot": self.robot, "order": self.order,
                "priority": self.priority, "charge_dock": self.charge_dock, "travel_m": round(self.travel_m, 3),
                "work_m": round(self.work_m, 3), "begin": round(self.begin, 3), "finish": round(self.finish, 3),
                "eta_s": round(self.finish - now, 3), "soc_after": round(self.soc_after, 4),
                "charge_s": round(self.charge_s, 1), "path": np.round(self.path, 3).tolist(),
                "task_ids": self.task_ids}


@dataclass(frozen=True, slots=True)
class Infeasible:
    request: str
    type: str
    reason: str


@dataclass
class Allocation:
    """The result of assign_tasks: who does what in which order, by when, along which path, at what cost."""

    method: str
    cost_model: str
    now: float
    dry_run: bool
    assignments: list[Assignment]
    infeasible: list[Infeasible]
    travel_m: float  # total approach travel (what allocation can change)
    work_m: float  # total distance of the work itself (the same whoever does it)
    makespan_s: float  # from now until the last task ends
    solve_time_s: float  # the solver alone (wall clock)
    table_time_s: float  # building the travel-cost table (wall clock)
    travel_lower_bound_m: float = 0.0  # no allocation of the same tasks travels less (see bound.py)

    @property
    def total_cost_m(self) -> float:
        return self.travel_m + self.work_m

    def to_dict(self) -> dict[str, Any]:
        return {"method": self.method, "cost_model": self.cost_model, "now": self.now, "dry_run": self.dry_run,
                "assignments": [a.to_dict(self.now) for a in self.assignments],
                "infeasible": [{"request": i.request, "type": i.type, "reason": i.reason} for i in self.infeasible],
                "travel_m": round(self.travel_m, 3), "work_m": round(self.work_m, 3),
                "total_cost_m": round(self.total_cost_m, 3), "makespan_s": round(self.makespan_s, 3),
                "travel_lower_bound_m": round(self.travel_lower_bound_m, 3),
                "solve_time_s": self.solve_time_s, "table_time_s": self.table_time_s}
