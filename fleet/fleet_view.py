"""The narrow view of the fleet that tasks, avoidance, swarm behaviours and the deadlock monitor work on.

Three parts, and nothing else of `FleetService` (so each subsystem can be built and tested alone on a
hand-built view, and none of them imports the service, which imports them):

- **snapshot arrays** (`robots`): one row per robot in world-table order, read-only numpy arrays, plus the
  sim time and the control period; the roles of each robot (who drives it, e-stop, its active task), asked
  when needed because sources earlier in the same control tick change them;
- **world queries**: static clearance, costmaps and keep-outs, the latest scan, docks and battery, the
  geofence, navigator construction;
- **a command sink**: publish an event, release a robot from whatever drives it. Velocities are not sent
  through the view: a task or behaviour returns its (v, ω) to the control loop, which filters and gates them.

`fleet.service_view.ServiceView` is the implementation over the running service.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from sim.errors import ErrorCode, unknown_name
from sim.types import Pose2D

if TYPE_CHECKING:
    from fleet.avoidance.clearance import StaticClearance
    from fleet.config import BatteryConfig
    from fleet.registry import RobotRecord
    from fleet.types import TaskState
    from planning import LayeredCostmap, Navigator
    from sim import LidarScan

COLUMNS = ("x", "y", "yaw", "v", "w", "radius", "max_v", "max_w")


@dataclass(frozen=True, slots=True, eq=False)
class RobotArrays:
    """The fleet's state in one control tick: ground-truth pose and body twist, footprint radius, limits."""

    names: tuple[str, ...]
    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    v: np.ndarray
    w: np.ndarray
    radius: np.ndarray  # footprint circle about base_link, m
    max_v: np.ndarray
    max_w: np.ndarray
    rows: Mapping[str, int]

    @staticmethod
    def of(names: Sequence[str], columns: Mapping[str, np.ndarray]) -> RobotArrays:
        """Read-only views of `columns` (no copy: the arrays follow the source until it reallocates)."""
        cols = {}
        for c in COLUMNS:
            a = np.asarray(columns[c], dtype=float).view()
            if a.shape != (len(names),):
                raise ValueError(f"column {c} has shape {a.shape}, expected ({len(names)},)")
            a.flags.writeable = False
            cols[c] = a
        names = tuple(names)
        return RobotArrays(names=names, rows={n: i for i, n in enumerate(names)}, **cols)

    def __len__(self) -> int:
        return len(self.names)

    def index(self, robot: str) -> int:
        """The robot's row; an unknown name raises UNKNOWN_ROBOT listing the robots."""
        i = self.rows.get(robot)
        if i is None:
            raise unknown_name("robot", robot, self.names, ErrorCode.UNKNOWN_ROBOT)
        return i

    def has(self, robot: str) -> bool:
        return robot in self.rows

    @property
    def xy(self) -> np.ndarray:
        """(n, 2) positions (a new array)."""
        return np.column_stack([self.x, self.y])

    @property
    def pose(self) -> np.ndarray:
        """(n, 3) x, y, yaw (a new array)."""
        return np.column_stack([self.x, self.y, self.yaw])

    def pose_of(self, robot: str) -> Pose2D:
        i = self.index(robot)
        return Pose2D(float(self.x[i]), float(self.y[i]), float(self.yaw[i]))

    def twist_of(self, robot: str) -> tuple[float, float]:
        i = self.index(robot)
        return float(self.v[i]), float(self.w[i])


class FleetView(Protocol):
    """Read-only for everything except the command sink (`publish`, `release`)."""

    # ---- snapshot -------------------------------------------------------------------------------------

    @property
    def robots(self) -> RobotArrays: ...

    @property
    def time(self) -> float: ...

    @property
    def control_dt(self) -> float: ...

    def owner(self, robot: str) -> str:
        """Who drives the robot: `task:<id>`, `behaviour:<id>`, `deadlock:<id>`, `manual` or `idle`."""
        ...

    def estopped(self, robot: str) -> bool: ...

    def avoidance_group(self, robot: str) -> int:
        """≥ 0 when the robot's swarm behaviour keeps its robots apart by itself (one number per behaviour)."""
        ...

    # Tasks are typed `Any` here: the task types depend on this view, not the other way round.
    def active_task(self, robot: str) -> Any | None: ...

    def active_tasks(self) -> Mapping[str, Any]: ...

    def task_state(self, task_id: str) -> TaskState: ...

    def robot_record(self, robot: str) -> RobotRecord:
        """What the registry knows of the robot (home, namespace); an unknown name raises UNKNOWN_ROBOT."""
        ...

    # ---- world queries --------------------------------------------------------------------------------

    def static_clearance(self) -> StaticClearance: ...

    @property
    def fence(self) -> tuple[float, float, float, float]: ...

    def latest_scan(self, robot: str) -> LidarScan | None: ...

    def costmap(self, robot: str) -> LayeredCostmap: ...

    def keepouts(self) -> list[list[tuple[float, float]]]: ...

    @property
    def docks(self) -> Mapping[str, Pose2D]: ...

    def battery_soc(self, robot: str) -> float: ...

    @property
    def battery_config(self) -> BatteryConfig: ...

    @property
    def barriers(self) -> Mapping[str, Any]: ...

    def make_navigator(self, robot: str, overrides: dict[str, Any] | None = None) -> Navigator: ...

    def traffic_layer(self, enable: Mapping[str, Any] | None = None) -> Any:
        """The fleet's traffic layer (fleet/traffic TrafficManager), or None; with `enable` (its settings) it is
        enabled when there is none."""
        ...

    # ---- command sink ---------------------------------------------------------------------------------

    def publish(self, stamp: float, kind: str, robots: Iterable[str] = (), message: str = "", **data: Any) -> None:
        ...

    def release(self, robot: str, reason: str) -> None:
        """Whatever drives the robot lets go of it (a behaviour taking it over)."""
        ...
