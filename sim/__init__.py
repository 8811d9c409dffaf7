"""sim: the PyBullet world — one client, sim-time clock, robots, sensors, world files, snapshots.

`World` is imported lazily (on first use) so light users of the value types — agents, parsers — do not pay for
PyBullet.
"""

from typing import TYPE_CHECKING, Any

from sim.clock import Clock, ClockMode
from sim.config import StrictModel, load_yaml
from sim.errors import ErrorCode, FleetError
from sim.robot_load import load_robot_model
from sim.robot_spec import RobotSpec, default_robot_path, load_robot_spec
from sim.sdf_parser import parse_sdf, parse_sdf_string
from sim.sdf_writer import save_sdf, write_sdf
from sim.types import (
    CameraImage,
    ContactReading,
    Fidelity,
    ImuReading,
    LidarScan,
    ModelDescription,
    OdometryReading,
    Pose2D,
    Pose3D,
    WorldDescription,
)
from sim.urdf_robot import LoadedRobot
from sim.world_types import CommandResult, ModelState
from sim.worldgen import cluttered_arena, warehouse

if TYPE_CHECKING:
    from sim.world import World


def __getattr__(name: str) -> Any:
    if name == "World":
        from sim.world import World

        return World
    raise AttributeError(f"module 'sim' has no attribute {name!r}")


__all__ = [
    "CameraImage",
    "Clock",
    "ClockMode",
    "CommandResult",
    "ContactReading",
    "ErrorCode",
    "Fidelity",
    "FleetError",
    "ImuReading",
    "LidarScan",
    "LoadedRobot",
    "ModelDescription",
    "ModelState",
    "OdometryReading",
    "Pose2D",
    "Pose3D",
    "RobotSpec",
    "StrictModel",
    "World",
    "WorldDescription",
    "cluttered_arena",
    "default_robot_path",
    "load_robot_model",
    "load_robot_spec",
    "load_yaml",
    "parse_sdf",
    "parse_sdf_string",
    "save_sdf",
    "warehouse",
    "write_sdf",
]
