"""Interfaces, configs and result types of the slam package.

Configs are StrictModel (pydantic, extra="forbid"), one section per stage, loaded with sim.config.load_yaml.
Results are frozen dataclasses holding plain numbers and numpy arrays, so callers (fleet, MCP tools) can
shape them without knowing how they were computed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from pydantic import Field, model_validator

from sim.config import StrictModel
from sim.types import LidarScan, Pose2D

# ---- configs ------------------------------------------------------------------------------------------


class OdometryConfig(StrictModel):
    """KISS-ICP scan-matching odometry, tuned for indoor 2D scans of ≤ 10 m."""

    voxel_size: float = Field(0.1, gt=0, description="local-map voxel edge, m")
    max_range: float = Field(10.0, gt=0)
    min_range: float = Field(0.15, ge=0)
    max_points_per_voxel: int = Field(20, ge=1)
    initial_threshold: float = Field(0.1, gt=0, description="first correspondence gate before adaptation, m")
    min_motion_th: float = Field(0.01, gt=0, description="motion below which the threshold is not adapted")
    max_iterations: int = Field(100, ge=1)
    convergence: float = Field(1e-4, gt=0)
    use_wheel_odometry: bool = Field(True, description="wheel odometry delta as ICP initial guess")
    refine_keyframes: bool = Field(True, description="point-to-line ICP between consecutive keyframes")
    refine_range_sigma: float = Field(0.03, gt=0, description="per-point σ behind the refined edge's information")
    # Per-metre and per-radian growth of the odometry standard deviations (the between-factor noise).
    sigma_xy_per_m: float = Field(0.01, gt=0)
    sigma_yaw_per_m: float = Field(0.002, gt=0)
    sigma_yaw_per_rad: float = Field(0.01, gt=0)
    sigma_floor_xy: float = Field(0.003, gt=0)
    sigma_floor_yaw: float = Field(0.001, gt=0)


class KeyframeConfig(StrictModel):
    distance: float = Field(1.0, gt=0, description="new keyframe after this much travel, m")
    angle: float = Field(0.5, gt=0, description="… or this much rotation, rad")


class LoopClosureConfig(StrictModel):
    enabled: bool = True
    search_radius: float = Field(4.0, gt=0, description="candidates within this distance in the estimate, m")
    min_separation: int = Field(10, ge=1, description="skip the last N keyframes (they are odometry)")
    max_candidates: int = Field(2, ge=1, description="ICP verifications per keyframe")
    descriptor_rings: int = Field(20, ge=2)
    descriptor_max_distance: float = Field(0.1, gt=0, description="ring-CDF earth mover's distance gate")
    icp_max_correspondence: float = Field(0.3, gt=0, description="m")
    icp_max_rmse: float = Field(0.05, gt=0, description="verified only if inlier RMSE below this, m")
    icp_min_inlier_ratio: float = Field(0.75, gt=0, le=1)
    icp_range_sigma: float = Field(0.03, gt=0, description="per-point σ behind the ICP information, m")
    sigma_floor_xy: float = Field(0.01, gt=0, description="loop-closure σ never below this, m")
    sigma_floor_yaw: float = Field(0.002, gt=0, description="rad")
    min_points: int = Field(60, ge=3)
    robust_kernel: Literal["cauchy", "huber", "none"] = "cauchy"
    kernel_width: float = Field(3.0, gt=0, description="in whitened (σ) units; gated inliers keep full weight")
    gate_chi2: float = Field(16.27, gt=0, description="Mahalanobis gate (χ², 3 dof, 99.9 %)")
    residual_chi2: float = Field(16.27, gt=0, description="reject if still this inconsistent after optimising")


class PoseGraphConfig(StrictModel):
    batch_on_loop_closure: bool = Field(False, description="also run batch Levenberg-Marquardt when a loop "
                                        "closes (iSAM2 is always the incremental optimiser)")
    relinearize_threshold: float = Field(0.001, gt=0, description="m or rad; robust weights refresh on relinearising")
    prior_sigma_xy: float = Field(1e-3, gt=0)
    prior_sigma_yaw: float = Field(1e-4, gt=0)


class MappingConfig(StrictModel):
    resolution: float = Field(0.05, gt=0, description="m per cell")
    log_odds_hit: float = Field(0.85, gt=0)
    log_odds_miss: float = Field(-0.4, lt=0)
    log_odds_min: float = -2.0
    log_odds_max: float = 3.5
    occupied_threshold: float = Field(0.65, gt=0, lt=1, description="probability above which a cell is occupied")
    free_threshold: float = Field(0.196, gt=0, lt=1)
    max_range: float = Field(10.0, gt=0)
    clear_no_return: bool = Field(True, description="beams without a return clear space up to max_range")

    @model_validator(mode="after")
    def _thresholds(self) -> MappingConfig:
        if self.free_threshold >= self.occupied_threshold:
            raise ValueError("free_threshold must be below occupied_threshold")
        return self


class LocalizationConfig(StrictModel):
    min_particles: int = Field(200, ge=10)
    max_particles: int = Field(4000, ge=10)
    kld_error: float = Field(0.02, gt=0)
    kld_z: float = Field(2.326, gt=0, description="upper standard-normal quantile (0.99)")
    bin_xy: float = Field(0.2, gt=0)
    bin_yaw: float = Field(math.radians(10), gt=0)
    beams: int = Field(60, ge=4, description="beams used per update")
    sigma_hit: float = Field(0.1, gt=0, description="likelihood-field σ, m")
    z_hit: float = Field(0.9, gt=0, le=1)
    z_rand: float = Field(0.1, ge=0, le=1)
    max_distance: float = Field(1.0, gt=0, description="distance-transform cap, m")
    alpha: tuple[float, float, float, float] = (0.05, 0.01, 0.05, 0.01)  # odometry noise, AMCL order
    alpha_slow: float = Field(0.002, gt=0, lt=1)
    alpha_fast: float = Field(0.1, gt=0, lt=1)
    lost_threshold: float = Field(0.1, ge=0, lt=1, description="injection probability that triggers global search")
    update_min_distance: float = Field(0.05, ge=0, description="filter update after this much motion, m")
    update_min_angle: float = Field(0.05, ge=0)
    icp_refine: bool = True
    icp_max_correspondence: float = Field(0.25, gt=0)

    @model_validator(mode="after")
    def _counts(self) -> LocalizationConfig:
        if self.max_particles < self.min_particles:
            raise ValueError("max_particles must be at least min_particles")
        return self


class SlamConfig(StrictModel):
    odometry: OdometryConfig = OdometryConfig()
    keyframes: KeyframeConfig = KeyframeConfig()
    loop_closure: LoopClosureConfig = LoopClosureConfig()
    pose_graph: PoseGraphConfig = PoseGraphConfig()
    mapping: MappingConfig = MappingConfig()
    lidar_offset: tuple[float, float, float] = Field((0.0, 0.0, 0.0), description="lidar in base_link: x y yaw")


# ---- results ------------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class ScanRecord:
    """One scan from any source (sim, CARMEN, MCAP) with the wheel-odometry pose at that time, if any."""

    scan: LidarScan
    odom: Pose2D | None = None


@dataclass(frozen=True, slots=True)
class IcpResult:
    pose: tuple[float, float, float]  # source frame expressed in the target frame
    rmse: float  # over inliers, m
    inlier_ratio: float
    iterations: int
    converged: bool
    information: np.ndarray  # 3×3 Hessian / σ² of the point-to-line problem (for the factor noise)

    def fits(self, max_rmse: float, min_inlier_ratio: float) -> bool:
        return self.converged and self.rmse <= max_rmse and self.inlier_ratio >= min_inlier_ratio


@dataclass(frozen=True, slots=True)
class OdometryStep:
    pose: Pose2D  # scan-matched pose of base_link in the odometry frame
    delta: tuple[float, float, float]  # motion since the previous scan, base_link frame
    points_used: int


@dataclass(frozen=True, slots=True)
class Keyframe:
    index: int
    stamp: float
    points: np.ndarray  # (n, 2) valid returns in base_link
    no_return_angles: np.ndarray  # beam angles (base_link) without a return, for free-space clearing
    descriptor: np.ndarray


@dataclass(frozen=True, slots=True)
class LoopClosure:
    source: int  # keyframe index (newer)
    target: int  # keyframe index (older)
    relative: tuple[float, float, float]  # source in target's frame
    rmse: float
    inlier_ratio: float
    accepted: bool
    reason: str  # "accepted" or why it was rejected


@dataclass(frozen=True, slots=True)
class SlamStatus:
    robot: str
    scans: int
    keyframes: int
    pose: Pose2D  # latest base_link pose in the map frame
    loop_closures_accepted: int
    loop_closures_rejected: int
    rejection_reasons: dict[str, int] = field(default_factory=dict)
    map_width: int = 0  # cells of the log-odds grid as last rendered
    map_height: int = 0
    map_current: bool = True  # False: loop closures moved the poses; the next map request re-renders
    skipped_scans: int = 0  # scans with fewer than 3 valid returns
    processing_time: float = 0.0  # s of wall time spent in process_scan
    scan_time: float = 0.0  # s of sensor time covered


@dataclass(frozen=True, slots=True)
class LocalizationQuality:
    spread_xy: float  # particle position standard deviation, m
    spread_yaw: float  # rad
    match_score: float  # fraction of beams within 2σ_hit of an obstacle at the estimate, 0..1
    ambiguity: float  # weight share outside the main mode, 0 (one mode) .. 1
    particles: int
    converged: bool


@dataclass(frozen=True, slots=True)
class LocalizationEstimate:
    pose: Pose2D
    covariance: np.ndarray  # 3×3
    quality: LocalizationQuality
    refined: bool  # True when scan-to-map ICP refined the filter mean
    injected: int  # random particles injected this update (kidnap recovery)


@dataclass(frozen=True, slots=True)
class TrajectoryErrors:
    ate_rmse: float  # m, after SE(2) alignment
    ate_mean: float
    ate_max: float
    rpe_trans_rmse: float  # m per `rpe_delta` step
    rpe_rot_rmse: float  # rad per step
    rpe_delta: int
    count: int
    alignment: tuple[float, float, float]  # the SE(2) transform applied to the estimate


@dataclass(frozen=True, slots=True)
class MapIoU:
    occupied: float  # IoU of occupied cells (with `tolerance_cells` slack)
    free: float  # IoU of free cells
    mean: float
    tolerance_cells: int
    coverage: float  # fraction of ground-truth free cells the map knows about
