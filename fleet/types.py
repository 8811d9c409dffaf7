"""Types of the fleet service: events, task states, the immutable state snapshot every front door reads."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any, Literal

import numpy as np

from sim.errors import ErrorCode, FleetError
from sim.types import Pose2D

__all__ = ["ErrorCode", "Event", "FleetError", "FleetSnapshot", "RobotView", "TaskState"]

ResponseFormat = Literal["summary", "normal", "full"]


class TaskState(StrEnum):
    QUEUED = "queued"
    ACTIVE = "active"
    SUCCEEDED = "succeeded"
    FAILED = "failed"
    CANCELED = "canceled"

    @property
    def done(self) -> bool:
        return self in (TaskState.SUCCEEDED, TaskState.FAILED, TaskState.CANCELED)


@dataclass(frozen=True, slots=True)
class Event:
    """Something that happened in the world, stamped with sim time. `seq` orders all events of a service."""

    seq: int
    stamp: float
    kind: str  # task_started, task_finished, task_failed, collision, near_miss, estop, rearm, deadlock, ...
    robots: tuple[str, ...] = ()
    message: str = ""
    data: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"seq": self.seq, "stamp": round(self.stamp, 6), "kind": self.kind, "robots": list(self.robots),
                "message": self.message, "data": self.data}


@dataclass(frozen=True, slots=True)
class RobotView:
    """One robot as the latest snapshot saw it."""

    name: str
    pose: Pose2D
    v: float
    w: float
    cmd_v: float
    cmd_w: float
    fidelity: str
    battery: float  # state of charge, 0..1
    controller: str  # idle | manual | task:<id> | behaviour:<id>
    estopped: bool
    in_collision: bool
    lease: str | None
    namespace: str

    def to_dict(self, fmt: ResponseFormat = "normal") -> dict[str, Any]:
        d: dict[str, Any] = {"name": self.name, "x": round(self.pose.x, 3), "y": round(self.pose.y, 3),
                             "yaw": round(self.pose.yaw, 3)}
        if fmt == "summary":
            return d
        d.update({"v": round(self.v, 3), "w": round(self.w, 3), "battery": round(self.battery, 3),
                  "controller": self.controller, "estopped": self.estopped, "in_collision": self.in_collision})
        if fmt == "full":
            d.update({"cmd_v": self.cmd_v, "cmd_w": self.cmd_w, "fidelity": self.fidelity, "lease": self.lease,
                      "namespace": self.namespace})
        return d


@dataclass(frozen=True)
class FleetSnapshot:
    """Immutable fleet state published after each control tick; reading it takes no lock.

    Arrays are read-only copies, one row per robot in `names` order."""

    time: float
    step_count: int
    world: str
    clock_mode: str
    real_time_factor: float
    names: tuple[str, ...]
    pose: np.ndarray  # (n, 3) x, y, yaw
    twist: np.ndarray  # (n, 2) v, w
    cmd: np.ndarray  # (n, 2)
    battery: np.ndarray  # (n,)
    in_collision: np.ndarray  # (n,) bool
    fidelity: tuple[str, ...]
    controller: tuple[str, ...]
    estopped: tuple[bool, ...]
    lease: tuple[str | None, ...]
    namespace: tuple[str, ...]
    fleet_estopped: bool = False
    active_tasks: int = 0
    last_event_seq: int = 0

    def index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            from sim.errors import unknown_name

            raise unknown_name("robot", name, self.names, ErrorCode.UNKNOWN_ROBOT) from None

    def robot(self, name: str) -> RobotView:
        i = self.index(name)
        return RobotView(name, Pose2D(*map(float, self.pose[i])), float(self.twist[i, 0]), float(self.twist[i, 1]),
                         float(self.cmd[i, 0]), float(self.cmd[i, 1]), self.fidelity[i], float(self.battery[i]),
                         self.controller[i], self.estopped[i], bool(self.in_collision[i]), self.lease[i],
                         self.namespace[i])

    def robots(self) -> list[RobotView]:
        return [self.robot(n) for n in self.names]

    def summary(self) -> dict[str, Any]:
        """A compact fleet summary: counts and aggregates, never one line per robot."""
        n = len(self.names)
        moving = int(np.count_nonzero(np.abs(self.twist[:, 0]) > 0.01)) if n else 0
        return {"time": round(self.time, 3), "world": self.world, "clock": self.clock_mode,
                "real_time_factor": round(self.real_time_factor, 2) if math.isfinite(self.real_time_factor) else None,
                "robots": n, "moving": moving, "in_collision": int(self.in_collision.sum()) if n else 0,
                "estopped": sum(self.estopped), "fleet_estopped": self.fleet_estopped,
                "active_tasks": self.active_tasks,
                "battery_min": round(float(self.battery.min()), 3) if n else None,
                "battery_mean": round(float(self.battery.mean()), 3) if n else None,
                "controllers": {c: self.controller.count(c) for c in sorted(set(
                    c.split(":")[0] for c in self.controller))} if n else {}}
