"""A URDF's Gazebo `<sensor>` blocks as the robot spec's sensor sections, with every missing value reported.

Gazebo spaces a ray sensor's `samples` rays evenly from min_angle to max_angle inclusive, and returns
samples × resolution ranges; fleetnav's lidar spaces `beams` rays fov/beams apart from -fov/2 (from -180° for
a full circle), so the field of view is (max - min) · samples / (samples - 1), capped at 360°. A block without
`<noise>` is simulated noise-free, as Gazebo does; a missing rate or range takes fleetnav's default and
says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from sim.robot_spec import CameraSpec, DepthCameraSpec, ImuSpec, LidarSpec
from sim.types import Pose3D
from sim.urdf_model import UrdfSensor

LIDAR_TYPES = ("ray", "gpu_ray", "gpu_lidar", "lidar")
DEPTH_TYPES = ("depth", "depth_camera", "rgbd_camera", "rgbd")


@dataclass
class SensorReport:
    """Spec sections built so far and what was defaulted (appended to the loader's warnings)."""

    warnings: list[str] = field(default_factory=list)

    def value(self, what: str, got: float | None, default: float, unit: str = "") -> float:
        if got is None:
            self.warnings.append(f"{what} not given: using {default:g}{unit}")
            return default
        return got

    def mount(self, sensor: UrdfSensor, pose: Pose3D) -> tuple[float, float, float]:
        if max(abs(pose.roll), abs(pose.pitch), abs(pose.yaw)) > 1e-3:
            self.warnings.append(f"sensor '{sensor.name}': mount rotation (rpy {pose.roll:.3f} {pose.pitch:.3f} "
                                 f"{pose.yaw:.3f}) ignored: fleetnav's {sensor.type} looks along base_link x")
        return pose.position


def pick(sensors: list[UrdfSensor], types: tuple[str, ...], report: SensorReport) -> UrdfSensor | None:
    found = [s for s in sensors if s.type in types]
    if len(found) > 1:
        report.warnings.append(f"{len(found)} {types[0]} sensors ({', '.join(s.name for s in found)}): "
                               f"simulating the first, '{found[0].name}'")
    return found[0] if found else None


def lidar_spec(s: UrdfSensor | None, mount: Pose3D, r: SensorReport) -> LidarSpec:
    if s is None:
        r.warnings.append("no ray/gpu_ray/gpu_lidar sensor: the lidar is disabled")
        return LidarSpec(enabled=False)
    d = LidarSpec()
    what = f"lidar '{s.name}'"
    samples = int(r.value(f"{what} <samples>", s.samples, d.beams))
    beams = max(4, round(samples * (s.resolution or 1.0)))
    if s.min_angle is None or s.max_angle is None:
        r.warnings.append(f"{what}: <min_angle>/<max_angle> not given: using a {d.fov_deg:g}° scan")
        fov = d.fov_deg
    else:
        span = s.max_angle - s.min_angle
        fov = min(360.0, math.degrees(span * samples / max(1, samples - 1)))
        fov = 360.0 if fov > 359.99 else fov  # a full circle written in rounded radians
        start = -180.0 if fov >= 360.0 - 1e-6 else -fov / 2
        if abs(math.degrees(s.min_angle) - start) > 0.5 and fov < 360.0 - 1e-6:
            r.warnings.append(f"{what}: scan from {math.degrees(s.min_angle):.1f}° is simulated centred on x "
                              f"(from {start:.1f}°)")
    rmin = r.value(f"{what} <range><min>", s.range_min, d.range_min, " m")
    rmax = r.value(f"{what} <range><max>", s.range_max, d.range_max, " m")
    if s.noise_stddev is None:
        r.warnings.append(f"{what}: no <noise>: simulated noise-free")
    return LidarSpec(rate_hz=r.value(f"{what} <update_rate>", s.update_rate, d.rate_hz, " Hz"), beams=beams,
                     fov_deg=fov, range_min=rmin, range_max=rmax, noise_std=s.noise_stddev or 0.0,
                     mount=r.mount(s, mount))


def camera_spec(s: UrdfSensor | None, mount: Pose3D, r: SensorReport) -> CameraSpec:
    if s is None:
        r.warnings.append("no camera sensor: the RGB camera is disabled")
        return CameraSpec(enabled=False)
    d, what = CameraSpec(), f"camera '{s.name}'"
    fov = math.degrees(s.horizontal_fov) if s.horizontal_fov is not None else None
    return CameraSpec(rate_hz=r.value(f"{what} <update_rate>", s.update_rate, d.rate_hz, " Hz"),
                      width=int(r.value(f"{what} <image><width>", s.image_width, d.width)),
                      height=int(r.value(f"{what} <image><height>", s.image_height, d.height)),
                      fov_deg=r.value(f"{what} <horizontal_fov>", fov, d.fov_deg, "°"),
                      near=r.value(f"{what} <clip><near>", s.range_min, d.near, " m"),
                      far=r.value(f"{what} <clip><far>", s.range_max, d.far, " m"), mount=r.mount(s, mount))


def depth_spec(s: UrdfSensor | None, r: SensorReport) -> DepthCameraSpec:
    if s is None:
        r.warnings.append("no depth sensor: the depth camera is disabled")
        return DepthCameraSpec(enabled=False)
    d, what = DepthCameraSpec(), f"depth camera '{s.name}'"
    plugin = s.plugin()

    def plugin_num(key: str) -> float | None:
        raw = plugin.param(key) if plugin else None
        return float(raw) if raw not in (None, "") else None

    fov = math.degrees(s.horizontal_fov) if s.horizontal_fov is not None else None
    lo = plugin_num("min_depth") or s.range_min
    hi = plugin_num("max_depth") or s.range_max
    return DepthCameraSpec(rate_hz=r.value(f"{what} <update_rate>", s.update_rate, d.rate_hz, " Hz"),
                           width=int(r.value(f"{what} <image><width>", s.image_width, d.width)),
                           height=int(r.value(f"{what} <image><height>", s.image_height, d.height)),
                           fov_deg=r.value(f"{what} <horizontal_fov>", fov, d.fov_deg, "°"),
                           range_min=r.value(f"{what} min depth", lo, d.range_min, " m"),
                           range_max=r.value(f"{what} max depth", hi, d.range_max, " m"),
                           noise_std=s.noise_stddev or 0.0)


def imu_spec(s: UrdfSensor | None, r: SensorReport) -> ImuSpec:
    if s is None:
        r.warnings.append("no imu sensor: the IMU is disabled")
        return ImuSpec(enabled=False)
    d, what = ImuSpec(), f"imu '{s.name}'"
    if s.noise_stddev is None or s.accel_noise_stddev is None:
        r.warnings.append(f"{what}: no angular_velocity/linear_acceleration <noise>: simulated noise-free")
    return ImuSpec(rate_hz=r.value(f"{what} <update_rate>", s.update_rate, d.rate_hz, " Hz"),
                   gyro_noise_std=s.noise_stddev or 0.0, accel_noise_std=s.accel_noise_stddev or 0.0)
