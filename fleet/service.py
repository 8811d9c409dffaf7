"""FleetService: the single façade every front door calls (MCP tools, Zenoh API, missions, grading).

Construct it, then `start()` for service mode (one sim thread, commands through a queue, futures back,
reads from the immutable snapshot) or call `advance()` / `step()` for batch mode (synchronous, as fast as
possible, no threads). Operations are grouped by concern in mixins over `fleet.core.ServiceCore`.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

from fleet.ops_calibration import CalibrationOps
from fleet.ops_debug import DebugOps
from fleet.ops_fleet import FleetOps
from fleet.ops_frames import FrameOps
from fleet.ops_keepouts import KeepoutOps
from fleet.ops_nav import NavOps
from fleet.ops_perception import PerceptionOps
from fleet.ops_robots import RobotOps
from fleet.ops_sim import SimOps
from fleet.ops_slam import SlamOps
from fleet.ops_tasks import TaskOps
from sim.errors import ErrorCode, FleetError


class FleetService(SimOps, RobotOps, NavOps, TaskOps, FleetOps, SlamOps, DebugOps, FrameOps, KeepoutOps,
                   PerceptionOps, CalibrationOps):
    def _init_extensions(self) -> None:
        self._init_task_ops()
        self._init_fleet_ops()
        self._init_slam_ops()
        self._init_debug_ops()
        self._init_perception_ops()
        self._init_calibration_ops()


# Operations that change the world, its fleet or files. With `service.read_only` set (a read-only server) each of
# them fails with UNSUPPORTED before reaching the sim thread: read-only is
# enforced here, not only by hiding tools. E-stop stays allowed (safety); reads, status and previews stay.
MUTATING = frozenset({
    "step", "advance", "reset", "load_world", "pause", "resume", "run_fast", "set_speed", "save_snapshot",
    "restore_snapshot", "save_world", "spawn_model", "delete_model", "set_model_state", "apply_force",
    "set_physics_properties", "spawn_robot", "remove_robot", "drive", "stop_robot", "rearm", "acquire_lease",
    "release_lease", "submit_task", "navigate", "cancel_task", "add_keepout", "clear_keepouts", "follow_waypoints",
    "cover_area", "follow_robot", "dock_and_charge", "return_home", "set_battery", "queue_task", "assign_tasks",
    "spawn_fleet", "fleet_command", "start_behaviour", "stop_behaviour", "set_avoidance", "configure_deadlocks",
    "start_slam", "stop_slam", "save_slam_map", "load_slam_map", "localize", "stop_localization",
    "start_calibration", "finish_calibration", "start_fusion", "stop_fusion", "add_marker", "clear_markers",
    "highlight_model", "network_markers", "restart", "run_slam_on_log"})


def _writable(name: str, fn: Callable[..., Any]) -> Callable[..., Any]:
    @functools.wraps(fn)
    def guarded(self: FleetService, *args: Any, **kwargs: Any) -> Any:
        if self.read_only:
            raise FleetError(ErrorCode.UNSUPPORTED, f"'{name}' changes the world; this service is read-only",
                             "use a server started without --read-only")
        return fn(self, *args, **kwargs)

    return guarded


for _name in MUTATING:
    if hasattr(FleetService, _name):
        setattr(FleetService, _name, _writable(_name, getattr(FleetService, _name)))
