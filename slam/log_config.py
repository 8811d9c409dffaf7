"""Config of the recorded-log SLAM (`fleetnav slam run`): one shared default for every log, no per-log tuning."""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field

from sim.config import StrictModel
from slam.densify import DensifyConfig
from slam.deskew import DeskewConfig
from slam.edge_switch import EdgeSwitchConfig
from slam.hypotheses import HypothesesConfig
from slam.lookahead import LookaheadConfig
from slam.loop_groups import LoopGroupConfig
from slam.match_covariance import MatchCovarianceConfig
from slam.max_mixture import SwitchableConfig
from slam.motion_prior import MotionPriorConfig
from slam.scan_refine import RefineConfig
from slam.types import MappingConfig


class FrontEndConfig(StrictModel):
    """Scan-to-local-map matching: correlative search around the odometry guess, then point-to-line ICP."""

    resolution: float = Field(0.05, gt=0, description="match grid cell, m")
    sigma: float = Field(0.07, gt=0, description="width of the hit likelihood around each map point, m")
    window_xy: float = Field(0.4, gt=0, description="search ± this around the odometry guess, m")
    window_yaw: float = Field(math.radians(20), gt=0, description="… and ± this, rad")
    wide_window_xy: float = Field(2.5, gt=0, description="window when there is no odometry or the match "
                                  "in the normal window is poor, m")
    wide_window_yaw: float = Field(math.radians(85), gt=0, description="rad")
    wide_min_score: float = Field(0.25, gt=0, lt=1, description="… in the wide window")
    wide_points: int = Field(80, ge=10, description="scan points scored by the wide search")
    min_score: float = Field(0.35, gt=0, lt=1, description="a match below this mean hit likelihood is poor")
    odometry_trust_xy: float = Field(0.1, ge=0, description="score penalty per m² away from the odometry "
                                     "guess (0: odometry only seeds the window)")
    odometry_trust_yaw: float = Field(0.1, ge=0, description="score penalty per rad² away from the guess")
    odom_step_sigma_xy: float = Field(0.03, gt=0, description="odometry prior fused with ICP: σ floor per "
                                      "step, m")
    odom_step_sigma_per_m: float = Field(0.1, ge=0, description="… plus this share of the step's length")
    odom_step_sigma_yaw: float = Field(0.02, gt=0, description="rad")
    odom_step_sigma_per_rad: float = Field(0.1, ge=0, description="… plus this share of the step's turn")
    odom_step_sigma_yaw_per_m: float = Field(0.02, ge=0, description="… plus rad per m travelled")
    csm_points: int = Field(160, ge=10, description="scan points (evenly subsampled) scored by the search")
    local_map_distance: float = Field(12.0, gt=0, description="local map: scans within this path length, m")
    local_map_scans: int = Field(30, ge=1, description="… and at most this many (evenly spaced)")
    icp_max_correspondence: float = Field(0.15, gt=0, description="m")
    icp_range_sigma: float = Field(0.05, gt=0, description="per-point σ behind the edge information, m")
    sigma_floor_xy: float = Field(0.01, gt=0, description="scan-matching edge σ never below this, m")
    sigma_floor_yaw: float = Field(0.003, gt=0, description="rad")
    sigma_floor_length: float | None = Field(1.0, gt=0, description="the floors hold for a step that covers "
                                             "this much ground; a step's floor variance scales with the ground "
                                             "it covered (None: the same floor for every step), m")
    sigma_floor_m_per_rad: float = Field(0.5, ge=0, description="a turn covers this much ground per rad, m")
    sigma_floor_min_share: float = Field(0.05, gt=0, le=1, description="… but never below this share of the "
                                         "floor variance")
    odom_sigma_xy: float = Field(0.2, gt=0, description="σ of an edge from odometry alone (match failed), m")
    odom_sigma_yaw: float = Field(0.1, gt=0, description="rad")
    deskew: DeskewConfig = Field(DeskewConfig(), description="interlaced-scan deskewing (`slam.deskew`)")
    refinement: Literal["icp", "smooth"] = Field("icp", description="sub-cell refinement of the correlative "
                                                 "match: point-to-line ICP, or the smooth (bicubic) map cost "
                                                 "of `slam.scan_refine` (ICP then only gives the edge's "
                                                 "information)")
    refine: RefineConfig = RefineConfig()
    local_map_min_log_odds: float | None = Field(None, description="local map: keep a point only if its cell's "
                                                 "log-odds summed over the window's scans (+0.85 per scan "
                                                 "with a return there, −0.4 per scan that saw through it) is "
                                                 "above this (None: keep every point; 0.5 measured: edmonton "
                                                 "0.44 → 0.26 m but orebro 0.89 → 3.7 m, see "
                                                 "docs/benchmarks-slam.md), see slam.submap_grid")


class LoopConfig(StrictModel):
    """Loop closure: candidates by pose uncertainty and descriptor, verified by branch-and-bound matching
    against a submap, added with a robust kernel and removed again if still inconsistent."""

    enabled: bool = True
    every_distance: float = Field(0.8, gt=0, description="try a scan for loops after this much travel, m")
    min_path_separation: float = Field(8.0, gt=0, description="only submaps at least this far back along "
                                       "the path (closer ones are the local map's job), m")
    radius_base: float = Field(1.0, gt=0, description="search radius = base + drift × path since the "
                               "submap (capped), m")
    radius_drift: float = Field(0.04, ge=0, description="radius growth per m of path (odometry drift)")
    radius_max: float = Field(4.0, gt=0, description="m")
    yaw_window: float = Field(math.radians(30), gt=0, description="rotation search ± this, rad")
    blind_radius_rate: float = Field(0.15, ge=0, description="the radius grows by this per m of *blind* path "
                                     "(steps the front end could not match: a laser dropout, a featureless "
                                     "hall; the estimate rode on the odometry; steps without odometry do not "
                                     "count) since the submap or the last closure, beyond `radius_max` (0: off), "
                                     "m/m")
    blind_radius_max: float = Field(10.0, gt=0, description="… at most this much more, m")
    blind_yaw_rate: float = Field(math.radians(1.0), ge=0, description="… and the rotation window by this, rad/m")
    blind_yaw_max: float = Field(math.radians(60), gt=0, description="… at most this much more, rad")
    blind_exclude_yaw: float = Field(math.radians(8), gt=0, description="a match in a widened window must "
                                     "stand out (`slam.loop_blind`): no pose of the window farther than 0.5 m "
                                     "(same rotation) or this (rad) from it may score above `weak_max_rival` "
                                     "of its score")
    max_candidates: int = Field(2, ge=1, description="submaps verified per scan")
    descriptor_rings: int = Field(24, ge=2)
    descriptor_max_distance: float = Field(0.15, gt=0, description="ring-CDF distance gate (0 … 1)")
    coverage: bool = Field(True, description="when no submap passes the candidate gates above, try the long "
                           "submaps (`coverage_submap_distance`) whose returns lie within the search radius of "
                           "enough of the scan's returns in the estimate, whatever the heading, longest loop "
                           "first (`slam.loop_coverage`); verified on those returns, must be distinct, and may "
                           "be weak (`weak_min_score`)")
    coverage_min_share: float = Field(0.4, gt=0, le=1, description="… share of the scan's returns covered")
    coverage_reach: float = Field(20.0, gt=0, description="… anchors farther than this from the scan are not "
                                  "looked at, m")
    coverage_candidates: int = Field(1, ge=1, description="… submaps verified per scan")
    coverage_points: int = Field(80, ge=10, description="… scan points scored by their branch and bound")
    coverage_angle_range: float = Field(5.0, gt=0, description="… whose rotation step moves a point this far "
                                        "away by one cell (ICP refines below it), m")
    coverage_submap_distance: float = Field(10.0, gt=0, description="… those submaps: scans within ± this "
                                            "path length, m")
    submap_distance: float = Field(4.0, gt=0, description="submap: scans within ± this path length, m")
    submap_spacing: float = Field(2.0, gt=0, description="a submap every this much path, m")
    resolution: float = Field(0.1, gt=0, description="verification grid cell, m")
    sigma: float = Field(0.1, gt=0, description="m")
    min_score: float = Field(0.55, gt=0, lt=1, description="branch-and-bound score to accept a match")
    min_inliers: float = Field(0.6, gt=0, le=1, description="ICP inlier share (within 0.1 m) to accept")
    weak_min_score: float | None = Field(0.35, gt=0, lt=1, description="a coverage match between this and "
                                         "`min_score` (or with inliers between `weak_min_inliers` and "
                                         "`min_inliers`) is never added alone: it waits as pending until a loop "
                                         "group agrees with it (`slam.loop_groups`; None: rejected)")
    weak_min_inliers: float = Field(0.35, gt=0, le=1, description="… ICP inlier share of a weak match")
    weak_max_rival: float = Field(0.9, gt=0, le=1, description="… and every coverage match must be "
                                  "distinct: no pose of the scan shifted more than 0.5 m (within the search "
                                  "radius) may score above this share of its score (a corridor's walls fit "
                                  "anywhere along it, and consecutive scans then agree on the same wrong shift)")
    max_rmse: float = Field(0.06, gt=0, description="ICP inlier RMSE to accept, m")
    min_points: int = Field(80, ge=10, description="scans with fewer returns are not tried")
    sigma_floor_xy: float = Field(0.03, gt=0, description="m")
    sigma_floor_yaw: float = Field(0.01, gt=0, description="rad")
    kernel: Literal["huber", "cauchy", "none"] = "huber"
    kernel_width: float = Field(1.0, gt=0, description="in σ units")
    strong_kernel_beyond: float | None = Field(0.3, gt=0, description="a closure that disagrees with the "
                                               "current estimate by more than this gets a Cauchy kernel "
                                               "(None: always `kernel`), m")
    residual_chi2: float = Field(16.27, gt=0, description="remove a closure still this inconsistent (χ², "
                                 "3 dof) after optimising")
    defer_chi2: float | None = Field(2.0, gt=0, description="a closure the estimate already satisfies (χ² "
                                     "at the estimate ≤ this) is added without optimising now; it is optimised "
                                     "and checked with the next one that needs it, or after `defer_distance` "
                                     "(None: optimise every closure at once), see slam.loop_batch")
    defer_distance: float = Field(20.0, gt=0, description="… at most this much path later, m")
    defer_after_nodes: int = Field(5000, ge=0, description="… only once the graph has this many nodes: below, "
                                   "optimising each closure at once costs < ~1 ms/scan of iSAM2 (freiburg-079, "
                                   "4.8k scans), and deferring moves the dev logs' ATE by −4 … +47 mm either "
                                   "way (chaotically, docs/benchmarks-slam.md, helper 14L)")
    max_built: int = Field(64, ge=1, description="frozen submaps that keep their match grids (the most "
                           "recently verified; the others rebuild theirs when verified again)")
    groups: LoopGroupConfig = LoopGroupConfig()
    edge_switch: EdgeSwitchConfig = EdgeSwitchConfig()


class LogSlamConfig(StrictModel):
    odometry: Literal["odom_increments", "laser_pose", "none"] = Field(
        "odom_increments", description="CARMEN odometry source: raw ODOM increments (honest), the laser "
        "lines' poses (a corrected reference in Radish logs), or none")
    laser: Literal["front", "rear"] = "front"
    max_range: float = Field(30.0, gt=0, description="returns beyond this are not used, m")
    min_range: float = Field(0.1, ge=0, description="m")
    point_spacing: float = Field(0.05, gt=0, description="scan points thinned to this spacing, m")
    frontend: FrontEndConfig = FrontEndConfig()
    motion_prior: MotionPriorConfig = MotionPriorConfig()
    match_covariance: MatchCovarianceConfig = MatchCovarianceConfig()
    hypotheses: HypothesesConfig = HypothesesConfig()
    lookahead: LookaheadConfig = LookaheadConfig()
    switchable: SwitchableConfig = SwitchableConfig()
    loops: LoopConfig = LoopConfig()
    densify: DensifyConfig = Field(DensifyConfig(), description="at the end of the log, every keyframe matched "
                                   "against its spatial neighbours in the optimised graph (`slam.densify`)")
    mapping: MappingConfig = MappingConfig(max_range=20.0, log_odds_miss=-0.2)  # hits outweigh grazing passes
    final_batch: bool = Field(False, description="also a batch Levenberg-Marquardt pass over the whole graph at "
                              "the end (measured: no change on freiburg-079, 0.089 m either way)")
    map_every_distance: float = Field(0.1, ge=0, description="integrate a scan into the final map after "
                                      "this much motion (or rotation / 10 rad·m), m")
