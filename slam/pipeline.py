"""SlamPipeline: one robot's online SLAM, a scan at a time.

`process_scan` is the recipe: preprocess → odometry → keyframe? → loop closure → optimise → map update.
The map is re-rendered from the optimised keyframe poses when the graph moved them (a loop closed);
otherwise each keyframe is integrated once. Each robot gets its own pipeline (see slam.merge to combine).
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from planning.grid import OccupancyGrid
from planning.map_io import save_map
from sim.transforms import se2_between, se2_compose, se2_inverse, wrap_angles
from sim.types import LidarScan, OdometryReading, Pose2D
from slam import se2
from slam.factories import make_loop_closer, make_mapper, make_odometry, make_pose_graph
from slam.keyframe_icp import refine_edge
from slam.loop_closure import ring_descriptor
from slam.types import Keyframe, LoopClosure, SlamConfig, SlamStatus


class SlamPipeline:
    def __init__(self, config: SlamConfig | None = None, robot: str = "robot",
                 initial_pose: Pose2D | None = None) -> None:
        """`initial_pose` places the map frame: the robot's pose at the first scan (default: the origin)."""
        self.config = cfg = config or SlamConfig()
        self.robot = robot
        self._start = (initial_pose or Pose2D()).as_tuple()
        self._odometry = make_odometry(cfg.odometry)
        self._graph = make_pose_graph(cfg.pose_graph)
        self._closer = make_loop_closer(cfg.loop_closure)
        self._mapper = make_mapper(cfg.mapping)
        self._lidar = cfg.lidar_offset
        self.keyframes: list[Keyframe] = []
        self._kf_odom: list[se2.PoseTuple] = []  # odometry-frame pose of each keyframe
        self._rendered = np.zeros((0, 3))  # keyframe poses the current map was rendered with
        self._scan_kf: list[int] = []  # per scan: the keyframe it hangs off, and its odometry-frame pose
        self._scan_odom: list[se2.PoseTuple] = []
        self._kf_scan: list[int] = []  # per keyframe: its scan's index
        self._stamps: list[float] = []
        self._last_wheel: Pose2D | None = None
        self._since_kf = (0.0, 0.0)  # path length and |rotation| since the last keyframe
        self._prev_odom: se2.PoseTuple = (0.0, 0.0, 0.0)
        self._busy = 0.0
        self.skipped = 0

    # ---- the recipe ----------------------------------------------------------------------------------

    def process_scan(self, scan: LidarScan, odom: Pose2D | OdometryReading | None = None) -> Pose2D:
        """Add one scan (and the wheel-odometry pose at its stamp, if any); returns the map-frame pose."""
        t0 = time.perf_counter()
        points, no_return = self._preprocess(scan)
        if len(points) < 3:
            self.skipped += 1  # nothing to match; the next scan's wheel delta covers the gap
            if self.keyframes:  # still one trajectory entry per scan: where the robot was last seen
                self._record_scan(scan.stamp, self._prev_odom)
            self._busy += time.perf_counter() - t0
            return self.pose
        step = self._odometry.register(points, self._wheel_delta(odom))
        odom_pose = step.pose.as_tuple()
        if self._is_keyframe(odom_pose):
            kf = self._add_keyframe(scan.stamp, points, no_return, odom_pose)
            self._close_loops(kf)
            self._graph.update()
            self._update_map(kf)
        self._record_scan(scan.stamp, odom_pose)
        self._busy += time.perf_counter() - t0
        return self.pose

    # ---- steps ---------------------------------------------------------------------------------------

    def _preprocess(self, scan: LidarScan) -> tuple[np.ndarray, np.ndarray]:
        """Valid returns in base_link, and the base_link angles of beams without a return."""
        r = scan.ranges
        ok = np.isfinite(r) & (r >= max(scan.range_min, self.config.odometry.min_range)) & (r <= scan.range_max)
        ang = scan.angles()
        pts = np.column_stack([r[ok] * np.cos(ang[ok]), r[ok] * np.sin(ang[ok])])
        return se2.transform_points(self._lidar, pts), ang[~np.isfinite(r)] + self._lidar[2]

    def _wheel_delta(self, odom: Pose2D | OdometryReading | None) -> se2.PoseTuple | None:
        if odom is None or not self.config.odometry.use_wheel_odometry:
            return None
        pose = odom.pose if isinstance(odom, OdometryReading) else odom
        prev, self._last_wheel = self._last_wheel, pose
        return None if prev is None else se2_between(prev.as_tuple(), pose.as_tuple())

    def _is_keyframe(self, odom_pose: se2.PoseTuple) -> bool:
        d = se2_between(self._prev_odom, odom_pose)
        self._prev_odom = odom_pose
        self._since_kf = (self._since_kf[0] + math.hypot(d[0], d[1]), self._since_kf[1] + abs(d[2]))
        kc = self.config.keyframes
        return not self.keyframes or self._since_kf[0] >= kc.distance or self._since_kf[1] >= kc.angle

    def _add_keyframe(self, stamp: float, points: np.ndarray, no_return: np.ndarray,
                      odom_pose: se2.PoseTuple) -> Keyframe:
        lc = self.config.loop_closure
        desc = ring_descriptor(points, lc.descriptor_rings, self.config.odometry.max_range)
        kf = Keyframe(len(self.keyframes), stamp, points, no_return, desc)
        if not self.keyframes:
            self._graph.add_pose(se2_compose(self._start, odom_pose))
        else:
            kiss_rel = se2_between(self._kf_odom[-1], odom_pose)
            prev = self._closer.target(self.keyframes[-1])
            rel, cov, _ = refine_edge(self.config.odometry, prev, points, kiss_rel, *self._since_kf)
            self._graph.add_pose(se2_compose(self._graph.pose(kf.index - 1), rel), rel, cov)
        self.keyframes.append(kf)
        self._kf_odom.append(odom_pose)
        self._kf_scan.append(len(self._stamps))
        self._since_kf = (0.0, 0.0)
        return kf

    def _close_loops(self, kf: Keyframe) -> None:
        if not self.config.loop_closure.enabled:
            return
        self._graph.update()  # candidates are searched in the up-to-date estimate
        for old in self._closer.candidates(kf, self.keyframes, self._graph.poses()):
            if self._closer.try_close(self._graph, kf, self.keyframes[old]).accepted:
                if self.config.pose_graph.batch_on_loop_closure:
                    self._graph.batch_optimize()
                break  # one verified closure per keyframe is enough to pull the graph

    def _update_map(self, kf: Keyframe) -> None:
        poses = self._graph.poses()
        n = len(self._rendered)
        moved = n and float(np.abs(poses[:n, :2] - self._rendered[:, :2]).max()) > 0.5 * self._mapper.resolution
        if moved:
            self._rendered = np.zeros((0, 3))  # stale: re-render lazily on the next map request
            self._mapper.clear()
        elif n == kf.index:  # map is current up to the previous keyframe: add this one
            self._integrate(kf, poses[kf.index])
            self._rendered = poses[: kf.index + 1].copy()

    def _integrate(self, kf: Keyframe, base_pose: np.ndarray) -> None:
        sensor = se2_compose((float(base_pose[0]), float(base_pose[1]), float(base_pose[2])), self._lidar)
        pts = se2.transform_points(se2_inverse(self._lidar), kf.points)
        self._mapper.integrate(sensor, pts, kf.no_return_angles - self._lidar[2])

    def _record_scan(self, stamp: float, odom_pose: se2.PoseTuple) -> None:
        self._scan_kf.append(len(self.keyframes) - 1)
        self._scan_odom.append(odom_pose)
        self._stamps.append(stamp)

    # ---- results -------------------------------------------------------------------------------------

    @property
    def pose(self) -> Pose2D:
        if not self._scan_kf:
            return Pose2D()
        i = self._scan_kf[-1]
        return Pose2D(*se2_compose(self._graph.pose(i), se2_between(self._kf_odom[i], self._scan_odom[-1])))

    def trajectory(self) -> tuple[np.ndarray, np.ndarray]:
        """(stamps (n,), poses (n, 3)) of every scan since the first one with returns, from the current
        (optimised) graph; a scan without returns repeats the previous pose.

        A scan between keyframes i and i+1 is placed by scan matching from both and the two are blended
        by how far along the interval it is, so the refined keyframe edge corrects the scans in between
        too. Scans after the last keyframe hang off it alone."""
        if not self._stamps:
            return np.zeros(0), np.zeros((0, 3))
        g, kfo, odo = self._graph.poses(), np.array(self._kf_odom), np.array(self._scan_odom)
        i = np.array(self._scan_kf)
        fwd = se2.compose_many(g[i], se2.between_many(kfo[i], odo))
        j = np.minimum(i + 1, len(g) - 1)
        back = se2.compose_many(g[j], se2.between_many(kfo[j], odo))
        first = np.array([*self._kf_scan, len(odo)])
        s = np.arange(len(odo))
        f = np.where(j > i, (s - first[i]) / np.maximum(first[j] - first[i], 1), 0.0)[:, None]
        diff = back - fwd
        diff[:, 2] = wrap_angles(diff[:, 2])
        out = fwd + f * diff
        out[:, 2] = wrap_angles(out[:, 2])
        return np.array(self._stamps), out

    def keyframe_poses(self) -> np.ndarray:
        return self._graph.poses()

    def batch_optimize(self) -> float:
        """Levenberg-Marquardt over the whole graph (the map re-renders on the next request)."""
        err = self._graph.batch_optimize()
        self._rendered = np.zeros((0, 3))
        self._mapper.clear()
        return err

    def map(self) -> OccupancyGrid:
        """The occupancy grid for the current estimate, re-rendered if loop closures moved the poses."""
        poses = self._graph.poses()
        if len(self._rendered) < len(self.keyframes):
            self._mapper.clear()
            for kf in self.keyframes:
                self._integrate(kf, poses[kf.index])
            self._rendered = poses.copy()
        return self._mapper.grid()

    def save_map(self, yaml_path: str | Path) -> Path:
        return save_map(self.map(), yaml_path)

    def add_loop_closure(self, target: int, source: int, relative: Pose2D, covariance: np.ndarray) -> LoopClosure:
        """An external loop closure (keyframe `source` seen from keyframe `target`, e.g. from a fiducial or
        another robot). It goes through the same consistency checks as the pipeline's own."""
        self._graph.update()
        closure = self._closer.add(self._graph, target, source, relative.as_tuple(), np.asarray(covariance))
        if closure.accepted:
            self._rendered = np.zeros((0, 3))  # the poses moved: re-render on the next map request
        return closure

    @property
    def loop_closures(self) -> list[LoopClosure]:
        return list(self._closer.history)

    def status(self) -> SlamStatus:
        h, w = self._mapper.log_odds.shape
        return SlamStatus(robot=self.robot, scans=len(self._stamps), keyframes=len(self.keyframes),
                          pose=self.pose, loop_closures_accepted=self._closer.accepted,
                          loop_closures_rejected=self._closer.rejected,
                          rejection_reasons=dict(self._closer.rejections), map_width=w, map_height=h,
                          map_current=len(self._rendered) == len(self.keyframes), skipped_scans=self.skipped,
                          processing_time=self._busy,
                          scan_time=(self._stamps[-1] - self._stamps[0]) if self._stamps else 0.0)

