"""Localisation in a known map: AMCL-like particle filter, then scan-to-map ICP refinement.

`update` reads like the recipe: motion (wheel odometry, or scan matching when there is none) → predict
→ (after enough motion) weight, resample with random injection → estimate → ICP refinement → quality.
A kidnapped robot shows up as a drop of the short-term scan likelihood against the long-term one; the
filter then injects random particles over the free space until a mode fits again.
"""

from __future__ import annotations

import math

import numpy as np

from planning.grid import OccupancyGrid
from sim.transforms import se2_between, se2_compose, wrap_angle
from sim.types import LidarScan, OdometryReading, Pose2D
from slam import se2
from slam.global_search import scan_proposals
from slam.grid_lookup import surface_points
from slam.icp import IcpTarget, icp
from slam.likelihood_field import LikelihoodField
from slam.odometry import KissOdometry
from slam.particle_filter import ParticleFilter
from slam.types import LocalizationConfig, LocalizationEstimate, LocalizationQuality


class Localizer:
    def __init__(self, grid: OccupancyGrid, config: LocalizationConfig | None = None, *, seed: int = 0,
                 lidar_offset: se2.PoseTuple = (0.0, 0.0, 0.0), max_range: float = 10.0) -> None:
        self.config = c = config or LocalizationConfig()
        self.grid = grid
        self._lidar = lidar_offset
        self._max_range = max_range
        self.field = LikelihoodField(grid, sigma_hit=c.sigma_hit, z_hit=c.z_hit, z_rand=c.z_rand,
                                     max_range=max_range, max_distance=c.max_distance)
        self.filter = ParticleFilter(self.field, np.random.default_rng(seed), min_particles=c.min_particles,
                                     max_particles=c.max_particles, kld_error=c.kld_error, kld_z=c.kld_z,
                                     bin_xy=c.bin_xy, bin_yaw=c.bin_yaw, alpha=c.alpha,
                                     alpha_slow=c.alpha_slow, alpha_fast=c.alpha_fast)
        self._target = IcpTarget.from_points(surface_points(grid)) if c.icp_refine else None
        self._scan_odom = KissOdometry(max_range=max_range)
        self._last_odom: Pose2D | None = None
        self._pending = (0.0, 0.0, 0.0)  # motion since the last sensor update
        self._snapshot: tuple[se2.PoseTuple, np.ndarray, float] | None = None  # mean, cov, main-mode share

    def initialize(self, pose: Pose2D | None = None, sigma_xy: float = 0.25, sigma_yaw: float = 0.2) -> None:
        """Start around `pose`, or everywhere in the free space (global localisation) when None."""
        if pose is None:
            self.filter.init_global()
        else:
            self.filter.init_pose(pose.as_tuple(), sigma_xy, sigma_yaw)
        self._pending = (math.inf, 0.0, 0.0)  # force a sensor update on the first scan
        self._snapshot = None

    def update(self, scan: LidarScan, odom: Pose2D | OdometryReading | None = None) -> LocalizationEstimate:
        if len(self.filter.particles) == 0:
            self.initialize(None)
        points = self._points(scan)
        delta = self._motion(points, odom)
        self.filter.predict(delta)
        moved = self._accumulate(delta)
        c = self.config
        if moved or self._snapshot is None:
            beams = points[np.linspace(0, len(points) - 1, min(c.beams, len(points))).astype(int)] \
                if len(points) else points
            self.filter.update(beams)
            # Read the weighted set before resampling: afterwards injected particles dilute it.
            mu, cov = self.filter.mean()
            snap = ((float(mu[0]), float(mu[1]), float(mu[2])), cov, self.filter.main_mode_share())
            lost = self.filter.p_inject > c.lost_threshold
            self.filter.resample(scan_proposals(self.field, points, self.filter.rng) if lost else None)
            self._pending = (0.0, 0.0, 0.0)
        else:  # between sensor updates the estimate moves with the odometry
            pose, cov, share = self._snapshot
            snap = (se2_compose(pose, delta), cov, share)
        self._snapshot = snap
        return self._estimate_from(points, *snap)

    # ---- steps ---------------------------------------------------------------------------------------

    def _points(self, scan: LidarScan) -> np.ndarray:
        r = scan.ranges
        ok = np.isfinite(r) & (r >= scan.range_min) & (r <= min(scan.range_max, self._max_range))
        a = scan.angles()[ok]
        return se2.transform_points(self._lidar, np.column_stack([r[ok] * np.cos(a), r[ok] * np.sin(a)]))

    def _motion(self, points: np.ndarray, odom: Pose2D | OdometryReading | None) -> se2.PoseTuple:
        """Base motion since the previous scan: wheel odometry if given, else scan-matching odometry."""
        if odom is not None:
            pose = odom.pose if isinstance(odom, OdometryReading) else odom
            prev, self._last_odom = self._last_odom, pose
            return (0.0, 0.0, 0.0) if prev is None else se2_between(prev.as_tuple(), pose.as_tuple())
        if len(points) < 3:
            return (0.0, 0.0, 0.0)
        return self._scan_odom.register(points).delta

    def _accumulate(self, delta: se2.PoseTuple) -> bool:
        d, a, _ = self._pending
        d += math.hypot(delta[0], delta[1])
        a += abs(delta[2])
        self._pending = (d, a, 0.0)
        return d >= self.config.update_min_distance or a >= self.config.update_min_angle

    def _estimate_from(self, points: np.ndarray, pose: se2.PoseTuple, cov: np.ndarray, share: float
                       ) -> LocalizationEstimate:
        """The filter's estimate, refined by scan-to-map ICP when the filter is confident enough."""
        refined = False
        if self._target is not None and len(points) >= 10 and math.sqrt(cov[0, 0] + cov[1, 1]) < 0.5:
            res = icp(points, self._target, pose, max_correspondence=self.config.icp_max_correspondence,
                      inlier_distance=0.1, range_sigma=self.grid.resolution)
            moved = math.hypot(res.pose[0] - pose[0], res.pose[1] - pose[1])
            if res.fits(0.05, 0.6) and moved < 0.5 and abs(wrap_angle(res.pose[2] - pose[2])) < 0.3:
                pose, refined = res.pose, True
        return LocalizationEstimate(pose=Pose2D(*pose), covariance=cov, refined=refined,
                                    quality=self._quality(pose, cov, share, points), injected=self.filter.injected)

    def _quality(self, pose: se2.PoseTuple, cov: np.ndarray, share: float, points: np.ndarray
                 ) -> LocalizationQuality:
        spread = math.sqrt(max(0.0, cov[0, 0] + cov[1, 1]))
        spread_yaw = math.sqrt(max(0.0, cov[2, 2]))
        d = self.field.distances(pose, points) if len(points) else np.zeros(0)
        score = float(np.mean(d < 2 * self.config.sigma_hit)) if len(d) else 0.0
        ambiguity = 1.0 - share
        return LocalizationQuality(spread_xy=spread, spread_yaw=spread_yaw, match_score=score, ambiguity=ambiguity,
                                   particles=len(self.filter.particles),
                                   converged=spread < 0.2 and score > 0.6 and ambiguity < 0.2)
