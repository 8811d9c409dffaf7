"""Result types and configs of the perception services (numpy + dataclasses, no PyBullet).

Frames: the camera frame is the camera *link* frame of `CameraImage.camera_pose` (x forward, y left, z up,
REP-103), not the optical frame; pixel (u, v) has u to the right and v down, (0, 0) the top-left pixel
centre. Depth is metres along the camera's x axis (z-buffer depth), as PyBullet renders it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from pydantic import Field

from sim.config import StrictModel
from sim.errors import ErrorCode, FleetError
from sim.types import Pose2D

Labeler = Callable[[int, int], tuple[str, str]]
"""(body_uid, link_index) -> (model name, link name); World provides it as `world.body_label`."""

AlertKind = Literal["dropout", "rate_low", "rate_high", "latency", "noise", "no_data"]


@dataclass(frozen=True, slots=True)
class CameraIntrinsics:
    """Pinhole intrinsics in pixels, square pixels; `fov_deg` everywhere is the horizontal FOV (Gazebo's
    horizontal_fov, as sim.types.CameraImage and RobotSpec cameras use it)."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int

    @staticmethod
    def from_fov(width: int, height: int, fov_deg: float,
                 principal_offset: tuple[float, float] = (0.0, 0.0)) -> CameraIntrinsics:
        """Intrinsics of a `width`×`height` image with horizontal FOV `fov_deg`: f = (w/2)/tan(fov/2) and
        the principal point at the image centre ((w−1)/2, (h−1)/2 with pixel centres on integers), moved
        by `principal_offset` (see projection.TINY_RENDERER_OFFSET)."""
        if width < 1 or height < 1 or not 0.0 < fov_deg < 180.0:
            raise FleetError(ErrorCode.INVALID_ARGUMENT,
                             f"bad camera model: {width}x{height} px, fov {fov_deg} deg",
                             "width and height ≥ 1 px, 0 < fov_deg < 180")
        f = 0.5 * width / math.tan(math.radians(fov_deg) / 2)
        du, dv = principal_offset
        return CameraIntrinsics(f, f, (width - 1) / 2 + du, (height - 1) / 2 + dv, width, height)

    def matrix(self) -> np.ndarray:
        """The 3×3 K of the optical frame (x right, y down, z forward)."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def vertical_fov_deg(self) -> float:
        return math.degrees(2 * math.atan(0.5 * self.height / self.fy))


@dataclass(frozen=True, slots=True)
class LabelMap:
    """Per-pixel labels: `ids[v, u]` indexes `labels` ((model, link) pairs); -1 is background/sky."""

    ids: np.ndarray  # (h, w) int32
    labels: tuple[tuple[str, str], ...]
    body_uids: tuple[int, ...]  # PyBullet body uid of each label
    link_indices: tuple[int, ...]  # PyBullet link index of each label (-1 = base)

    def label_at(self, u: int, v: int) -> tuple[str, str] | None:
        i = int(self.ids[v, u])
        return None if i < 0 else self.labels[i]

    def model_mask(self, model: str) -> np.ndarray:
        """Boolean (h, w) mask of every pixel of `model` (all its links)."""
        keep = [i for i, (m, _) in enumerate(self.labels) if m == model]
        return np.isin(self.ids, keep)

    def models(self) -> list[str]:
        return sorted({m for m, _ in self.labels})


@dataclass(frozen=True, slots=True)
class Detection:
    """One visible object: a model (or one link of it, when grouping by link) in one camera image."""

    label: str  # model name, or "model/link" when grouped by link
    model: str
    links: tuple[str, ...]
    box: tuple[int, int, int, int]  # (u_min, v_min, u_max, v_max), inclusive pixel indices
    pixel_count: int
    distance: float | None  # median depth of its valid depth pixels, m (None without depth)
    position: tuple[float, float, float] | None  # world frame, median of back-projected pixels, m

    @property
    def width_px(self) -> int:
        return self.box[2] - self.box[0] + 1

    @property
    def height_px(self) -> int:
        return self.box[3] - self.box[1] + 1

    def to_dict(self) -> dict[str, Any]:
        return {"label": self.label, "model": self.model, "links": list(self.links), "box": list(self.box),
                "pixel_count": self.pixel_count, "distance": self.distance,
                "position": None if self.position is None else list(self.position)}


@dataclass(frozen=True, slots=True)
class Obstacle:
    """A cluster of points: centroid, axis-aligned extent (max − min per axis) and point count."""

    centre: tuple[float, ...]
    extent: tuple[float, ...]
    count: int
    radius: float  # largest distance of a member point from the centroid, m


@dataclass(frozen=True, slots=True)
class SectorMinimum:
    """The nearest return in one angular sector of a scan (lidar frame); inf range when it saw nothing."""

    index: int
    angle_start: float
    angle_end: float
    min_range: float
    angle: float  # bearing of the nearest return (sector centre when empty), rad


@dataclass(frozen=True, slots=True)
class GroundPlane:
    """n·p + d = 0 with a unit normal pointing up (n_z > 0); `inliers` marks ground points."""

    normal: tuple[float, float, float]
    d: float
    inliers: np.ndarray  # bool (n,)


@dataclass(frozen=True, slots=True)
class EkfState:
    """The filter's estimate in the odom frame: pose, body velocities, 5×5 covariance (x y yaw v ω)."""

    stamp: float
    x: float
    y: float
    yaw: float
    v: float
    w: float
    covariance: np.ndarray

    @property
    def pose(self) -> Pose2D:
        return Pose2D(self.x, self.y, self.yaw)


@dataclass(frozen=True, slots=True)
class HealthAlert:
    stream: str
    kind: AlertKind
    message: str
    stamp: float  # sim time the condition was detected


@dataclass(frozen=True, slots=True)
class StreamHealth:
    """One sensor stream's health over the monitor's window, evaluated at sim time `stamp`."""

    stream: str
    stamp: float
    configured_hz: float
    measured_hz: float
    latency_mean: float  # receive time − stamp, s
    latency_max: float
    dropouts: int  # gaps longer than k × period seen so far (an ongoing silence counts)
    longest_gap: float  # s
    silent_for: float  # time since the last reading, s
    noise_std: float | None  # estimated white-noise σ of the stream's values (None: not enough data)
    quality: float  # 0 (unusable) … 1 (nominal)
    alerts: tuple[HealthAlert, ...] = field(default_factory=tuple)

    @property
    def ok(self) -> bool:
        return not self.alerts


@dataclass(frozen=True, slots=True)
class ImuBias:
    """IMU biases from a stationary window (gravity removed from the accelerometer)."""

    accel: tuple[float, float, float]  # m/s², body frame
    gyro: tuple[float, float, float]  # rad/s
    accel_std: tuple[float, float, float]  # per-axis sample σ of the window
    gyro_std: tuple[float, float, float]
    samples: int


@dataclass(frozen=True, slots=True)
class LidarOffsetEstimate:
    """The lidar's planar mounting pose in base_link estimated by scan-to-map alignment."""

    offset: Pose2D
    rms_residual: float  # point-to-map distance of the inliers after alignment, m
    inliers: int
    scans: int
    truth: Pose2D | None = None
    error_xy: float | None = None  # |estimate − truth| in metres (when the truth is known)
    error_yaw: float | None = None  # rad


@dataclass(frozen=True, slots=True)
class ScanProjection:
    """Lidar returns inside a camera image: pixel (u, v), depth along the camera axis, beam index."""

    uv: np.ndarray  # (k, 2) float pixels
    depth: np.ndarray  # (k,) m
    beams: np.ndarray  # (k,) int index into LidarScan.ranges


# ---- configs (YAML sections; factories turn them into keyword arguments) ------------------------------


class EkfConfig(StrictModel):
    """Noise of the 2D EKF (σ values; the covariances are their squares)."""

    accel_std: float = Field(1.0, gt=0, description="process noise: unmodelled linear acceleration, m/s²")
    alpha_std: float = Field(2.0, gt=0, description="process noise: unmodelled angular acceleration, rad/s²")
    odom_v_std: float = Field(0.05, gt=0, description="wheel odometry linear velocity, m/s")
    odom_w_std: float = Field(0.1, gt=0, description="wheel odometry yaw rate, rad/s")
    gyro_std: float = Field(0.01, gt=0, description="IMU yaw rate, rad/s")
    pose_xy_std: float = Field(0.05, gt=0, description="absolute / scan-matching pose position, m")
    pose_yaw_std: float = Field(0.02, gt=0, description="absolute / scan-matching pose yaw, rad")
    use_accel: bool = Field(False, description="drive the v prediction with the IMU's forward acceleration")


class StreamConfig(StrictModel):
    """What a sensor stream is supposed to do, and when to raise an alert."""

    rate_hz: float = Field(gt=0)
    dropout_factor: float = Field(3.0, gt=1, description="a gap > factor × period is a dropout")
    window_s: float = Field(2.0, gt=0, description="sliding window for rate, latency and noise, s")
    max_latency: float = Field(0.1, ge=0, description="s")
    nominal_noise: float | None = Field(None, ge=0, description="expected σ of the values; None: no check")
    noise_factor: float = Field(2.0, gt=1, description="alert when the noise σ exceeds factor × nominal")
    min_rate_ratio: float = Field(0.8, gt=0, le=1, description="alert below this fraction of rate_hz")
