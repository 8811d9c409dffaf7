"""FleetService configuration: one nested pydantic model, one section per service (`extra="forbid"`)."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field

from fleet.safety import SafetyConfig
from sim.config import StrictModel


class BatteryConfig(StrictModel):
    capacity_wh: float = Field(100.0, gt=0)
    idle_w: float = Field(5.0, ge=0, description="electronics draw, W")
    drive_wh_per_m: float = Field(0.05, ge=0, description="traction energy per metre travelled")
    charge_w: float = Field(200.0, gt=0, description="charging power at a dock, W")
    low_threshold: float = Field(0.2, gt=0, lt=1, description="state of charge that raises low_battery")
    dock_radius: float = Field(0.5, gt=0, description="a robot within this of a dock charges when still")


class FleetConfig(StrictModel):
    world: str = Field("empty", description="a world name in configs/worlds or a path to an SDF file")
    physics_hz: float = Field(100.0, ge=1, le=2000)
    control_hz: float = Field(10.0, ge=1, le=200, description="rate of navigators, behaviours, avoidance")
    seed: int = 0
    fidelity: Literal["kinematic", "dynamic"] = "kinematic"
    robot_model: str = Field("diffbot", description="a shipped robot model name, a .yaml/.urdf/.urdf.xacro file, "
                             "or URDF/xacro text")
    package_path: list[str] = Field(default_factory=list, description="folders holding ROS packages for a robot "
                                    "description's package:// and $(find), searched before FLEETNAV_PACKAGE_PATH, "
                                    "ROS_PACKAGE_PATH and AMENT_PREFIX_PATH")
    safety: SafetyConfig = Field(default_factory=SafetyConfig)
    battery: BatteryConfig = Field(default_factory=BatteryConfig)
    navigation: dict[str, Any] = Field(default_factory=dict, description="planning.NavigatorConfig fields")
    costmap_resolution: float = Field(0.05, gt=0.005, le=1.0)
    near_miss_distance: float = Field(0.3, ge=0, description="robot-robot clearance that counts as a near miss")
    avoidance: dict[str, Any] = Field(default_factory=lambda: {"type": "orca"},
                                      description="multi-robot avoidance plugin; {type: none} disables it")
    deadlock: dict[str, Any] = Field(default_factory=dict,
                                     description="fleet.deadlock.DeadlockConfig fields (policy, thresholds)")
    workspace: str | None = Field(None, description="the only directory file arguments may read (writes go to its "
                                  "outputs/ folder); omitted: a dedicated folder, ~/.local/share/fleetnav/workspace")
