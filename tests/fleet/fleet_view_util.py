"""A hand-built FleetView for tests: a few robots on an occupancy grid, no FleetService and no PyBullet.

The test owns the arrays (it moves the robots itself); roles are plain dicts; the world queries are answered
from the grid with the real planning classes; the command sink records what it is sent.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from fleet.avoidance.clearance import StaticClearance
from fleet.config import BatteryConfig
from fleet.fleet_view import RobotArrays
from fleet.registry import RobotRecord
from fleet.types import TaskState
from planning import LayeredCostmap, Navigator, NavigatorConfig, OccupancyGrid, make_navigator
from sim import LidarScan, RobotSpec
from sim.types import Pose2D


class HandView:
    def __init__(self, names: list[str], pose: npt.ArrayLike, *, radius: float = 0.2, max_v: float = 0.6,
                 max_w: float = 2.0, grid: OccupancyGrid | None = None, control_dt: float = 0.1) -> None:
        n = len(names)
        self.names = list(names)
        self.pose = np.asarray(pose, dtype=float).reshape(n, 3).copy()
        self.twist = np.zeros((n, 2))
        self.radius, self.max_v, self.max_w = np.full(n, radius), np.full(n, max_v), np.full(n, max_w)
        self.grid = grid if grid is not None else OccupancyGrid.empty((-10.0, -10.0, 10.0, 10.0), 0.1)
        self.now, self._dt = 0.0, control_dt
        self.owners: dict[str, str] = {}
        self.stopped: set[str] = set()
        self.groups: dict[str, int] = {}
        self.tasks: dict[str, Any] = {}  # robot → its active task
        self.events: list[tuple[float, str, tuple[str, ...], str, dict[str, Any]]] = []
        self.released: list[tuple[str, str]] = []
        self._costmaps: dict[str, LayeredCostmap] = {}
        self._clearance = StaticClearance(self.grid)

    # ---- snapshot -------------------------------------------------------------------------------------

    @property
    def robots(self) -> RobotArrays:
        p, t = self.pose, self.twist
        return RobotArrays.of(self.names, {"x": p[:, 0], "y": p[:, 1], "yaw": p[:, 2], "v": t[:, 0], "w": t[:, 1],
                                           "radius": self.radius, "max_v": self.max_v, "max_w": self.max_w})

    @property
    def time(self) -> float:
        return self.now

    @property
    def control_dt(self) -> float:
        return self._dt

    def owner(self, robot: str) -> str:
        return self.owners.get(robot, "idle")

    def estopped(self, robot: str) -> bool:
        return robot in self.stopped

    def avoidance_group(self, robot: str) -> int:
        return self.groups.get(robot, -1)

    def active_task(self, robot: str) -> Any | None:
        return self.tasks.get(robot)

    def active_tasks(self) -> Mapping[str, Any]:
        return self.tasks

    def task_state(self, task_id: str) -> TaskState:
        return next(t.state for t in self.tasks.values() if t.id == task_id)

    def robot_record(self, robot: str) -> RobotRecord:
        return RobotRecord(robot, "diffbot", robot, self.robots.pose_of(robot), "kinematic", 0.0)

    # ---- world queries --------------------------------------------------------------------------------

    def static_clearance(self) -> StaticClearance:
        return self._clearance

    @property
    def fence(self) -> tuple[float, float, float, float]:
        return self.grid.bounds

    def latest_scan(self, robot: str) -> LidarScan | None:
        return None  # no sensors in a hand-built fleet

    def costmap(self, robot: str) -> LayeredCostmap:
        if robot not in self._costmaps:
            self._costmaps[robot] = LayeredCostmap(self.grid, robot_radius=float(self.radius[self.names.index(robot)]))
        return self._costmaps[robot]

    def keepouts(self) -> list[list[tuple[float, float]]]:
        return []

    @property
    def docks(self) -> Mapping[str, Pose2D]:
        return {}

    def battery_soc(self, robot: str) -> float:
        return 1.0

    @property
    def battery_config(self) -> BatteryConfig:
        return BatteryConfig()

    @property
    def barriers(self) -> Mapping[str, Any]:
        return {}

    def make_navigator(self, robot: str, overrides: dict[str, Any] | None = None) -> Navigator:
        return make_navigator(NavigatorConfig.model_validate(overrides or {}), costmap=self.costmap(robot),
                              spec=RobotSpec())

    def traffic_layer(self, enable: Mapping[str, Any] | None = None) -> Any:
        return None  # a hand-built view has no traffic layer

    # ---- command sink ---------------------------------------------------------------------------------

    def publish(self, stamp: float, kind: str, robots: Iterable[str] = (), message: str = "", **data: Any) -> None:
        self.events.append((stamp, kind, tuple(robots), message, data))

    def release(self, robot: str, reason: str) -> None:
        self.released.append((robot, reason))
