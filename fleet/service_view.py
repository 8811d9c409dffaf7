"""ServiceView: the narrow fleet view (fleet/fleet_view.py) over a running FleetService.

One per built world. The snapshot arrays are read-only views of the world table's columns, so steps and
teleports (which write the columns in place) show at once without a copy; they are rebuilt only when the
table reallocates its columns (a robot spawned or removed, a snapshot restored). Roles and queries are
forwarded when asked, so they are as current as the service itself.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING, Any

from fleet.fleet_view import RobotArrays

if TYPE_CHECKING:
    from fleet.avoidance.clearance import StaticClearance
    from fleet.config import BatteryConfig
    from fleet.registry import RobotRecord
    from fleet.service import FleetService
    from fleet.types import TaskState
    from planning import LayeredCostmap, Navigator
    from sim import LidarScan
    from sim.types import Pose2D


class ServiceView:
    def __init__(self, service: FleetService) -> None:
        self._svc = service
        self._arrays: RobotArrays | None = None
        self._source: Any = None  # the column the arrays view: a new one means the table reallocated

    # ---- snapshot -------------------------------------------------------------------------------------

    @property
    def robots(self) -> RobotArrays:
        t = self._svc.world.table
        x = t.f["x"]
        if self._arrays is None or self._source is not x:
            self._arrays, self._source = RobotArrays.of(t.names, t.f), x
        return self._arrays

    @property
    def time(self) -> float:
        return self._svc.world.time

    @property
    def control_dt(self) -> float:
        return 1.0 / self._svc.config.control_hz

    def owner(self, robot: str) -> str:
        return self._svc.control.owner(robot)

    def estopped(self, robot: str) -> bool:
        return self._svc.safety.is_estopped(robot)

    def avoidance_group(self, robot: str) -> int:
        return self._svc.behaviours.avoidance_group(robot)

    def active_task(self, robot: str) -> Any | None:
        return self._svc.tasks.active.get(robot)

    def active_tasks(self) -> Mapping[str, Any]:
        return self._svc.tasks.active

    def task_state(self, task_id: str) -> TaskState:
        return self._svc.tasks.get(task_id).state

    def robot_record(self, robot: str) -> RobotRecord:
        return self._svc.registry.get(robot)

    # ---- world queries --------------------------------------------------------------------------------

    def static_clearance(self) -> StaticClearance:
        return self._svc.static_clearance()

    @property
    def fence(self) -> tuple[float, float, float, float]:
        return self._svc.safety.fence

    def latest_scan(self, robot: str) -> LidarScan | None:
        return self._svc.world.latest_scan(robot)

    def costmap(self, robot: str) -> LayeredCostmap:
        return self._svc.costmap_for(robot)

    def keepouts(self) -> list[list[tuple[float, float]]]:
        return self._svc.list_keepouts()

    @property
    def docks(self) -> Mapping[str, Pose2D]:
        return self._svc.docks

    def battery_soc(self, robot: str) -> float:
        return float(self._svc.battery.soc[self._svc.world.table.index(robot)])

    @property
    def battery_config(self) -> BatteryConfig:
        return self._svc.config.battery

    @property
    def barriers(self) -> Mapping[str, Any]:
        return self._svc.barriers

    def make_navigator(self, robot: str, overrides: dict[str, Any] | None = None) -> Navigator:
        return self._svc.make_navigator(robot, overrides)

    def traffic_layer(self, enable: Mapping[str, Any] | None = None) -> Any:
        from fleet.traffic.layer import ensure_traffic, traffic_layer

        return traffic_layer(self._svc) if enable is None else ensure_traffic(self._svc, dict(enable))

    # ---- command sink ---------------------------------------------------------------------------------

    def publish(self, stamp: float, kind: str, robots: Iterable[str] = (), message: str = "", **data: Any) -> None:
        self._svc.events.publish(stamp, kind, robots, message, **data)

    def release(self, robot: str, reason: str) -> None:
        self._svc.control.release(robot, reason)
