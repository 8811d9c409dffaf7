"""Factories: config sections in, keyword-only constructors called with plain arguments."""

from __future__ import annotations

from slam.loop_closure import LoopCloser
from slam.mapping import OccupancyMapper
from slam.odometry import KissOdometry
from slam.pose_graph import PoseGraph
from slam.types import LoopClosureConfig, MappingConfig, OdometryConfig, PoseGraphConfig


def make_odometry(c: OdometryConfig) -> KissOdometry:
    return KissOdometry(voxel_size=c.voxel_size, max_range=c.max_range, min_range=c.min_range,
                        max_points_per_voxel=c.max_points_per_voxel, initial_threshold=c.initial_threshold,
                        min_motion_th=c.min_motion_th, max_iterations=c.max_iterations,
                        convergence=c.convergence)


def make_pose_graph(c: PoseGraphConfig) -> PoseGraph:
    return PoseGraph(prior_sigmas=(c.prior_sigma_xy, c.prior_sigma_xy, c.prior_sigma_yaw),
                     relinearize_threshold=c.relinearize_threshold)


def make_loop_closer(c: LoopClosureConfig) -> LoopCloser:
    return LoopCloser(search_radius=c.search_radius, min_separation=c.min_separation,
                      max_candidates=c.max_candidates, descriptor_max_distance=c.descriptor_max_distance,
                      icp_max_correspondence=c.icp_max_correspondence, icp_max_rmse=c.icp_max_rmse,
                      icp_min_inlier_ratio=c.icp_min_inlier_ratio, min_points=c.min_points,
                      icp_range_sigma=c.icp_range_sigma, sigma_floor_xy=c.sigma_floor_xy,
                      sigma_floor_yaw=c.sigma_floor_yaw, kernel=c.robust_kernel, kernel_width=c.kernel_width,
                      gate_chi2=c.gate_chi2, residual_chi2=c.residual_chi2)


def make_mapper(c: MappingConfig) -> OccupancyMapper:
    return OccupancyMapper(resolution=c.resolution, log_odds_hit=c.log_odds_hit, log_odds_miss=c.log_odds_miss,
                           log_odds_min=c.log_odds_min, log_odds_max=c.log_odds_max,
                           occupied_threshold=c.occupied_threshold, free_threshold=c.free_threshold,
                           max_range=c.max_range, clear_no_return=c.clear_no_return)
