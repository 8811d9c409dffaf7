"""The differential-drive robot, defined once (configs/robots/*.yaml) and turned into URDF by sim.urdf.

Defaults are the course robot: chassis 0.5 × 0.4 × 0.2 m, wheels r = 0.1 m, separation 0.4 m, a caster,
a 0.3 m sensor mast, ≈ 5 kg, lidar 360°/1°/0.1–10 m/10 Hz, RGB 640×480/60°/30 Hz, depth 320×240/0.5–5 m,
IMU 100 Hz, odometry 50 Hz.
"""

from __future__ import annotations

import math
from pathlib import Path

from pydantic import Field, model_validator

from sim.config import StrictModel, load_yaml
from sim.types import Pose3D

Vec3 = tuple[float, float, float]


class ChassisSpec(StrictModel):
    size: Vec3 = (0.5, 0.4, 0.2)
    mass: float = Field(3.25, gt=0)
    ground_clearance: float = Field(0.05, ge=0, description="gap between floor and chassis bottom")
    rgba: tuple[float, float, float, float] = (0.15, 0.35, 0.75, 1.0)


class WheelSpec(StrictModel):
    radius: float = Field(0.1, gt=0)
    width: float = Field(0.05, gt=0)
    separation: float = Field(0.4, gt=0, description="distance between wheel centres")
    mass: float = Field(0.5, gt=0)
    friction: float = Field(1.0, ge=0, description="lateral (Coulomb) friction coefficient")
    rolling_friction: float = Field(0.001, ge=0)
    spinning_friction: float = Field(0.001, ge=0)
    max_torque: float = Field(10.0, gt=0, description="motor torque limit, N·m")
    left_joints: tuple[str, ...] = Field(("left_wheel_joint",), min_length=1,
                                         description="driven left wheel joints (several for 4-wheel bases)")
    right_joints: tuple[str, ...] = Field(("right_wheel_joint",), min_length=1)


class CasterSpec(StrictModel):
    radius: float = Field(0.05, gt=0)
    x_offset: float = Field(-0.2, description="caster centre relative to the chassis centre, m")
    mass: float = Field(0.25, gt=0)
    friction: float = Field(0.01, ge=0, description="low: a caster slides")


class MastSpec(StrictModel):
    height: float = Field(0.3, gt=0)
    radius: float = Field(0.025, gt=0)
    x_offset: float = 0.0
    mass: float = Field(0.5, gt=0)


class LimitsSpec(StrictModel):
    max_linear: float = Field(1.0, gt=0, description="m/s")
    max_angular: float = Field(2.0, gt=0, description="rad/s")
    max_linear_accel: float = Field(1.5, gt=0, description="m/s²")
    max_angular_accel: float = Field(4.0, gt=0, description="rad/s²")


class LidarSpec(StrictModel):
    enabled: bool = True
    rate_hz: float = Field(10.0, gt=0)
    beams: int = Field(360, ge=4)
    fov_deg: float = Field(360.0, gt=0, le=360)
    range_min: float = Field(0.1, gt=0)
    range_max: float = Field(10.0, gt=0)
    noise_std: float = Field(0.01, ge=0, description="range noise σ, m")
    mount_z: float = Field(0.02, description="lidar origin above the mast top, m")
    mount: Vec3 | None = Field(None, description="lidar origin in base_link (from a URDF); None: on the mast")

    @model_validator(mode="after")
    def _ranges(self) -> LidarSpec:
        if self.range_max <= self.range_min:
            raise ValueError("range_max must exceed range_min")
        return self

    @property
    def resolution_deg(self) -> float:
        return self.fov_deg / self.beams


class CameraSpec(StrictModel):
    enabled: bool = True
    rate_hz: float = Field(30.0, gt=0)
    width: int = Field(640, ge=8)
    height: int = Field(480, ge=8)
    fov_deg: float = Field(60.0, gt=0, lt=180)
    near: float = Field(0.05, gt=0)
    far: float = Field(30.0, gt=0)
    mount: Vec3 | None = Field(None, description="camera origin in base_link (from a URDF); None: chassis front")


class DepthCameraSpec(StrictModel):
    enabled: bool = True
    rate_hz: float = Field(15.0, gt=0)
    width: int = Field(320, ge=8)
    height: int = Field(240, ge=8)
    fov_deg: float = Field(60.0, gt=0, lt=180)
    range_min: float = Field(0.5, gt=0)
    range_max: float = Field(5.0, gt=0)
    noise_std: float = Field(0.005, ge=0)


class ImuSpec(StrictModel):
    enabled: bool = True
    rate_hz: float = Field(100.0, gt=0)
    accel_noise_std: float = Field(0.02, ge=0, description="m/s²")
    gyro_noise_std: float = Field(0.002, ge=0, description="rad/s")
    accel_bias: Vec3 = (0.0, 0.0, 0.0)
    gyro_bias: Vec3 = (0.0, 0.0, 0.0)


class OdometrySpec(StrictModel):
    enabled: bool = True
    rate_hz: float = Field(50.0, gt=0)
    slip_std: float = Field(0.02, ge=0, description="relative wheel-increment noise (slip), σ")
    wheel_radius_error: float = Field(0.0, description="relative error of the radius the encoder assumes")


class SensorsSpec(StrictModel):
    lidar: LidarSpec = LidarSpec()
    camera: CameraSpec = CameraSpec()
    depth: DepthCameraSpec = DepthCameraSpec()
    imu: ImuSpec = ImuSpec()
    odometry: OdometrySpec = OdometrySpec()
    contact: bool = True


class RobotSpec(StrictModel):
    name: str = "diffbot"
    chassis: ChassisSpec = ChassisSpec()
    wheels: WheelSpec = WheelSpec()
    caster: CasterSpec = CasterSpec()
    mast: MastSpec = MastSpec()
    limits: LimitsSpec = LimitsSpec()
    sensors: SensorsSpec = SensorsSpec()
    extent: tuple[float, float, float, float] | None = Field(
        None, description="(x_min, x_max, y_min, y_max) of the collision geometry in base_link (from a URDF); "
        "None: chassis and wheels")
    description: str | None = Field(None, description="URDF file the robot is built from, its root on the floor "
                                    "under the axle centre (sim.urdf_robot); None: generated from this spec")

    @model_validator(mode="after")
    def _geometry(self) -> RobotSpec:
        if self.wheels.separation <= self.wheels.width:
            raise ValueError("wheels.separation must exceed wheels.width")
        if abs(self.caster.x_offset) > self.chassis.size[0] / 2:
            raise ValueError("caster.x_offset puts the caster outside the chassis")
        return self

    # Derived geometry used by the drive models, sensors and planners.
    @property
    def total_mass(self) -> float:
        return self.chassis.mass + 2 * self.wheels.mass + self.caster.mass + self.mast.mass

    @property
    def chassis_z(self) -> float:
        """Height of the chassis centre above the floor when the wheels touch it."""
        return self.wheels.radius + self.chassis_offset_z

    @property
    def chassis_offset_z(self) -> float:
        """Chassis centre height relative to the wheel axle."""
        return self.chassis.ground_clearance + self.chassis.size[2] / 2 - self.wheels.radius

    @property
    def lidar_height(self) -> float:
        """Lidar origin height above the floor."""
        if self.sensors.lidar.mount is not None:
            return self.sensors.lidar.mount[2]
        return self.chassis_z + self.chassis.size[2] / 2 + self.mast.height + self.sensors.lidar.mount_z

    @property
    def footprint_radius(self) -> float:
        """Radius of the smallest circle about base_link holding chassis and wheels (for planners)."""
        if self.extent is not None:
            x0, x1, y0, y1 = self.extent
            return math.hypot(max(abs(x0), abs(x1)), max(abs(y0), abs(y1)))
        half_x = self.chassis.size[0] / 2
        half_y = max(self.chassis.size[1] / 2, self.wheels.separation / 2 + self.wheels.width / 2)
        return math.hypot(half_x, half_y)

    @property
    def camera_mount(self) -> Pose3D:
        """Camera link pose in base_link: the URDF's mount, else on the chassis front face, 3 cm below its
        top, looking forward."""
        if self.sensors.camera.mount is not None:
            return Pose3D(*self.sensors.camera.mount)
        return Pose3D(self.chassis.size[0] / 2 + 0.01, 0.0, self.chassis_z + self.chassis.size[2] / 2 - 0.03)

    @property
    def footprint(self) -> list[tuple[float, float]]:
        """Footprint polygon (base_link frame, CCW): chassis plus wheels, or the URDF's collision extent."""
        if self.extent is not None:
            x0, x1, y0, y1 = self.extent
            return [(x1, y0), (x0, y0), (x0, y1), (x1, y1)]  # the same vertex order as below
        hx = self.chassis.size[0] / 2
        hy = max(self.chassis.size[1] / 2, self.wheels.separation / 2 + self.wheels.width / 2)
        return [(hx, hy), (-hx, hy), (-hx, -hy), (hx, -hy)][::-1]


def load_robot_spec(path: str | Path) -> RobotSpec:
    return load_yaml(path, RobotSpec)


def default_robot_path() -> Path:
    from sim.resources import shipped

    return shipped("robots", "diffbot.yaml")
