"""FleetService: the single façade every front door calls (MCP tools, Zenoh API, missions, grading).

Construct it, then `start()` for service mode (one sim thread, commands through a queue, futures back,
reads from the immutable snapshot) or call `advance()` / `step()` for batch mode (synchronous, as fast as
possible, no threads). Operations are grouped by concern in mixins over `fleet.core.ServiceCore`.
"""

from __future__ import annotations

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


class FleetService(SimOps, RobotOps, NavOps, TaskOps, FleetOps, SlamOps, DebugOps, FrameOps, KeepoutOps,
                   PerceptionOps, CalibrationOps):
    def _init_extensions(self) -> None:
        self._init_task_ops()
        self._init_fleet_ops()
        self._init_slam_ops()
        self._init_debug_ops()
        self._init_perception_ops()
        self._init_calibration_ops()
