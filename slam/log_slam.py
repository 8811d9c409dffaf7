"""SLAM for recorded logs: every scan is a pose-graph node.

Front end: the scan is matched against a local map (the recent scans at their current poses) by a
correlative branch-and-bound search in a window around the odometry guess (`slam.csm`), then refined by
point-to-line ICP. Odometry only seeds the window and adds a small score penalty (its trust); when it is
missing, or the match in the normal window is poor, a wide window is searched; near-tied peaks of a wide
match are decided by the next scans (`slam.lookahead`). If no match is found the edge falls back to odometry
with a loose σ. Loop closures are `slam.log_loops`; the graph is GTSAM's
(`slam.pose_graph.PoseGraph`).
"""

from __future__ import annotations

import bisect
import math
import time
from collections.abc import Sequence

import gtsam
import numpy as np

from planning.grid import OccupancyGrid
from sim.transforms import se2_between, se2_compose
from sim.types import LidarScan, Pose2D
from slam import se2
from slam.alloc import retain_freed_memory
from slam.csm import CsmResult, MatchGrid, search, subsample, thin
from slam.densify import Densifier
from slam.deskew import InterlaceDeskew, step_velocity
from slam.edge_switch import Surface
from slam.hypotheses import WideSearch, alternative, decide, escalated
from slam.icp import IcpTarget, icp
from slam.log_config import LogSlamConfig
from slam.log_loops import LoopFinder
from slam.log_stats import FrontEndStats, scan_map
from slam.lookahead import alternatives, choose, free_space_penalty
from slam.match_covariance import ambiguous_covariance, translation_surface
from slam.max_mixture import max_mixture_factor, switchable
from slam.motion_models import with_models
from slam.motion_prior import predicted_step
from slam.pose_graph import PoseGraph
from slam.scan_refine import BicubicField, refine
from slam.submap_grid import HitMissGrid
from slam.surface_fill import fill_surfaces


class LogSlam:
    def __init__(self, config: LogSlamConfig | None = None, initial_pose: Pose2D | None = None) -> None:
        self.config = cfg = config or LogSlamConfig()
        retain_freed_memory()  # per-scan grids reuse heap pages instead of faulting new ones (slam.alloc)
        self.graph = PoseGraph(prior_sigmas=(1e-3, 1e-3, 1e-4))
        self.poses: list[se2.PoseTuple] = []
        self.points: list[np.ndarray] = []  # thinned returns per node, base frame
        self.no_return: list[np.ndarray] = []
        self.path: list[float] = []  # cumulative path length at each node
        self.blind: list[float] = []  # … of it on steps the front end could not match, on odometry
        self.stamps: list[float] = []
        self.odometry: list[se2.PoseTuple | None] = []
        self.stats = FrontEndStats()
        self.edges: list[tuple[int, int, se2.PoseTuple, np.ndarray]] = []  # kept factors, for graph.g2o
        self._start = (initial_pose or Pose2D()).as_tuple()
        self._local: tuple[MatchGrid, IcpTarget] | None = None
        self._local_at = -1  # node index the local map was last built at
        self._local_pose: se2.PoseTuple = (0.0, 0.0, 0.0)
        self._local_filled = False
        self._filled: dict[int, np.ndarray] = {}  # node → its filled returns, while in the local map window
        self._evidence = HitMissGrid(cfg.frontend.resolution)
        self._following: list[LidarScan] = []
        self._local_pts = np.zeros((0, 2))  # the match grid's points (world frame), for look-ahead maps
        self._local_idx = np.zeros(0, dtype=np.int64)  # … and its scans
        self._surface: tuple[np.ndarray, np.ndarray] | None = None  # the wide match's translation score surface
        self._wide = False
        self.surfaces: dict[int, Surface] = {}  # node → score surface of its wide match
        self._mixtures: dict[int, object] = {}  # node → its incoming max-mixture edge (kept alive here)
        self._deskew = InterlaceDeskew(cfg.frontend.deskew) if cfg.frontend.deskew.enabled else None
        self.loops = LoopFinder(cfg.loops, self)
        self.densifier = Densifier(cfg.densify, self)
        fe = cfg.frontend
        self._edge_floor = np.diag([fe.sigma_floor_xy ** 2, fe.sigma_floor_xy ** 2, fe.sigma_floor_yaw ** 2])
        self._odom_cov = np.diag([fe.odom_sigma_xy ** 2, fe.odom_sigma_xy ** 2, fe.odom_sigma_yaw ** 2])
        mp = cfg.motion_prior
        self._prior_cov = np.diag([mp.sigma_xy ** 2, mp.sigma_xy ** 2, mp.sigma_yaw ** 2])

    # ---- per scan ------------------------------------------------------------------------------------

    def add_scan(self, scan: LidarScan, odom: Pose2D | None = None, odom_valid: bool = True,
                 lookahead: LidarScan | Sequence[LidarScan] | None = None,
                 rate: tuple[float, float, float, float] | None = None) -> Pose2D:
        """`lookahead`: the next scan(s), if known (a log), to settle a weak or near-tied wide match
        (`slam.hypotheses`, `slam.lookahead`). `rate`: the odometry's (vx, vy, ω) at the scan's stamp and the
        interval it was measured over, if known (`slam.deskew`)."""
        t0, c0 = time.perf_counter(), time.process_time()
        cfg = self.config
        self._following = [] if lookahead is None else [lookahead] if isinstance(lookahead, LidarScan) \
            else list(lookahead)
        o = odom.as_tuple() if odom is not None else None
        i = len(self.poses)
        pts, no_ret = self._preprocess(scan, self._velocity(scan.stamp, o, odom_valid, rate))
        if i == 0:
            pose = self._start
            self.graph.add_pose(pose)
            self._append(scan.stamp, pose, pts, no_ret, o, 0.0)
            self.blind.append(0.0)
            self.stats.times.append(time.perf_counter() - t0)
            self.stats.cpu_times.append(time.process_time() - c0)
            return Pose2D(*pose)
        prev = self.poses[-1]
        has_odom = odom_valid and o is not None and self.odometry[-1] is not None
        if has_odom:
            delta = se2_between(self.odometry[-1], o)  # type: ignore[arg-type]
        else:  # no odometry: the motion prior (constant velocity) seeds the wide window
            delta = predicted_step(self.poses, cfg.motion_prior.constant_velocity)
        guess = se2_compose(prev, delta)
        matched, cov = self._match(pts, guess, has_odom, delta)
        if matched is None:
            self.stats.odometry_only += 1
            pose, rel, cov = guess, delta, self._odom_cov if has_odom else self._prior_cov
        else:
            pose, rel = matched, se2_between(prev, matched)
        self.graph.add_pose(pose, rel, cov, self._switchable(i, rel, cov) if matched is not None else None)
        self.edges.append((i - 1, i, rel, cov))
        step = math.hypot(rel[0], rel[1])
        self._append(scan.stamp, pose, pts, no_ret, o, self.path[-1] + step)
        # dead reckoning on odometry drifts at a bounded rate the loop search can widen for; a step with
        # neither (the motion prior's guess) has no such bound
        self.blind.append(self.blind[-1] + (step if matched is None and has_odom else 0.0))
        if cfg.loops.enabled:
            self.loops.step(i)
        self.stats.times.append(time.perf_counter() - t0)
        self.stats.cpu_times.append(time.process_time() - c0)
        return Pose2D(*self.poses[-1])

    def _append(self, stamp: float, pose: se2.PoseTuple, pts: np.ndarray, no_ret: np.ndarray,
                odom: se2.PoseTuple | None, path: float) -> None:
        self.poses.append(pose)
        self.points.append(pts)
        self.no_return.append(no_ret)
        self.odometry.append(odom)
        self.stamps.append(stamp)
        self.path.append(path)

    def _velocity(self, stamp: float, odom: se2.PoseTuple | None, odom_valid: bool,
                  rate: tuple[float, float, float, float] | None) -> se2.PoseTuple | None:
        if self._deskew is None or not self.poses:
            return None
        if rate is not None and self._deskew.config.odometry_rate:
            return (rate[0], rate[1], rate[2])  # the ODOM lines resolve the motion finer than the scans
        return step_velocity(stamp, self.stamps, self.odometry[-1] if odom_valid else None, odom, self.poses,
                             self._deskew.config.max_interval)

    def _preprocess(self, scan: LidarScan, velocity: se2.PoseTuple | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Valid returns as points (deskewed if `frontend.deskew` and `velocity` is known), thinned, and the
        angles of the beams without a return."""
        cfg = self.config
        r = scan.ranges
        ang = scan.angles()
        ok = np.isfinite(r) & (r >= max(cfg.min_range, scan.range_min)) & (r <= min(cfg.max_range, scan.range_max))
        pts = np.column_stack([r[ok] * np.cos(ang[ok]), r[ok] * np.sin(ang[ok])])
        if self._deskew is not None and velocity is not None:
            pts = self._deskew.process(pts, r[ok], (np.nonzero(ok)[0] % 2) == 1, velocity)
        return thin(pts, cfg.point_spacing), ang[~np.isfinite(r)]

    def _match(self, pts: np.ndarray, guess: se2.PoseTuple, has_odom: bool, delta: se2.PoseTuple
               ) -> tuple[se2.PoseTuple | None, np.ndarray]:
        fe = self.config.frontend
        if len(pts) < 10:
            return None, self._odom_cov
        local = self._local_map(fill=not has_odom)
        if local is None:  # the window's scans saw nothing (a laser blackout longer than the window)
            return None, self._odom_cov
        grid, target = local
        sub = subsample(pts, fe.csm_points)
        res = None
        if has_odom:
            res = search(grid, sub, guess, window_xy=fe.window_xy, window_yaw=fe.window_yaw,
                         min_score=fe.min_score, prior_weight_xy=fe.odometry_trust_xy,
                         prior_weight_yaw=fe.odometry_trust_yaw)
        wide = res is None
        wp = subsample(pts, fe.wide_points)  # the wide searches' points
        if wide:
            res = search(grid, wp, guess, window_xy=fe.wide_window_xy,
                         window_yaw=fe.wide_window_yaw, min_score=fe.wide_min_score, top_level=4,
                         max_range_for_step=5.0, prior_weight_xy=self.config.motion_prior.weight_xy,
                         prior_weight_yaw=self.config.motion_prior.weight_yaw)
        mp = self.config.motion_prior
        ws = WideSearch(fe.wide_window_xy, fe.wide_window_yaw, fe.wide_min_score, mp.weight_xy, mp.weight_yaw)
        if wide and (res is None or ws.at_edge(res.pose, guess, grid.resolution)):
            res = escalated(ws, grid, wp, guess, self.config.hypotheses.escalate)
        seeded: list[CsmResult] = []  # other motion models' matches (`slam.motion_models`)
        if wide and not has_odom:
            res, seeded = with_models(ws, grid, wp, self.poses, guess, res, self.config.hypotheses.models)
        if res is None:
            return None, self._odom_cov
        self._surface = None
        if wide and self._following:
            following = [self._preprocess(s)[0] for s in self._following]
            hy, extra = self.config.hypotheses, []
            if hy.to_lookahead and self.config.lookahead.enabled:
                alt = alternative(grid, wp, res, guess, ws, hy)
                extra = ([] if alt is None else [alt]) + seeded
            else:
                res = decide(grid, wp, res, self.poses[-1], guess, subsample(following[0], fe.wide_points), ws, hy)
            if res is None:
                return None, self._odom_cov
            res = self._look_ahead(grid, pts, res, guess, following, ws, not has_odom, extra)
        fit = icp(pts, target, res.pose, max_correspondence=fe.icp_max_correspondence,
                  inlier_distance=fe.icp_max_correspondence, range_sigma=fe.icp_range_sigma)
        pose = fit.pose
        if not fit.converged or math.hypot(pose[0] - res.pose[0], pose[1] - res.pose[1]) > 2 * grid.resolution:
            pose = res.pose  # ICP wandered off the correlative optimum: keep the lattice pose
        self._wide = wide
        if fe.refinement == "smooth":
            ref = refine(BicubicField(grid.field, grid.origin, grid.resolution), pts, res.pose, fe.refine)
            if math.hypot(ref.pose[0] - res.pose[0], ref.pose[1] - res.pose[1]) <= 2 * grid.resolution:
                pose = ref.pose
        if wide:
            self.stats.wide += 1
        else:
            self.stats.matched += 1
        info = fit.information + 1e-9 * np.eye(3)
        if wide:  # a second peak nearly as good (a corridor): the edge is weak along it
            wp, mc = subsample(pts, fe.wide_points), self.config.match_covariance
            surface = self._surface or translation_surface(grid, wp, pose, fe.wide_window_xy, mc.step)
            self.surfaces[len(self.poses)] = Surface.of(*surface, pose)  # for slam.edge_switch
            amb = ambiguous_covariance(grid, wp, pose, fe.wide_window_xy, fe.wide_window_yaw, mc, surface)
            if amb is not None:
                self.stats.ambiguous += 1
                return pose, np.linalg.inv(info) + self._edge_floor + amb
        if has_odom and not wide:  # fuse with the odometry prior: it holds where the scan is degenerate
            odo_info = np.linalg.inv(self._step_cov(delta))
            d = np.array(se2_between(guess, pose))
            fused = np.linalg.solve(info + odo_info, info @ d)
            pose = se2_compose(guess, (float(fused[0]), float(fused[1]), float(fused[2])))
            info = info + odo_info
        return pose, np.linalg.inv(info) + self._floor(se2_between(self.poses[-1], pose))

    def _look_ahead(self, grid: MatchGrid, pts: np.ndarray, res: CsmResult, guess: se2.PoseTuple,
                    following: list[np.ndarray], ws: WideSearch, fill: bool, extra: list[CsmResult]
                    ) -> CsmResult:
        """`res`, or a near-tied distinct peak of its score surface (or one of `extra`) that the next scans
        match better from."""
        la, fe, mp = self.config.lookahead, self.config.frontend, self.config.motion_prior
        if not la.enabled:
            return res
        wp = subsample(pts, fe.wide_points)
        surface = translation_surface(grid, wp, res.pose, fe.wide_window_xy, self.config.match_covariance.step)
        self._surface = surface  # the edge's covariance reuses it (ICP moves the pose less than a cell)
        alts = alternatives(grid, wp, res, guess, surface, la, (mp.weight_xy, mp.weight_yaw))
        alts += [e for e in extra if all(math.hypot(e.pose[0] - h.pose[0], e.pose[1] - h.pose[1]) >= la.min_separation
                                         or abs(math.remainder(e.pose[2] - h.pose[2], math.tau)) >= la.refine_yaw
                                         for h in [res, *alts])]
        if not alts:
            return res

        def grid_of(chain: list[tuple[se2.PoseTuple, np.ndarray]]) -> MatchGrid:
            extra = [se2.transform_points(p, fill_surfaces(q, fe.resolution / 2, mp.fill_ratio, mp.fill_max_gap)
                                          if fill else q) for p, q in chain]
            return MatchGrid(thin(np.vstack([self._local_pts, *extra]), fe.resolution / 2), fe.resolution,
                             fe.sigma, margin=(1.5 + 2 * fe.wide_window_xy if fill else 1.0))

        ahead = [(subsample(f, la.points), f) for f in following[:la.depth]]
        others = [(self.poses[k], self.points[k]) for k in self._local_idx]
        best, _ = choose([res, *alts], self.poses[-1], pts, ahead, grid_of, ws.run,
                         free_space_penalty(others, la))
        self.stats.lookahead += 1
        self.stats.lookahead_switched += best is not res
        if best is not res:
            self._surface = None
        return best

    def _switchable(self, i: int, rel: se2.PoseTuple, cov: np.ndarray) -> gtsam.CustomFactor | None:
        """A wide match's edge as a max-mixture with a broad null component (`slam.max_mixture`): a wrong
        corridor peak can then be overridden by agreeing loop closures."""
        sw = self.config.switchable
        if not (sw.enabled and self._wide):
            return None
        factor, mix = max_mixture_factor(i - 1, i, switchable(rel, cov, sw.null_sigma_xy, sw.null_sigma_yaw,
                                                              sw.null_weight))
        self._mixtures[i] = mix
        return factor

    def _floor(self, rel: se2.PoseTuple) -> np.ndarray:
        """The edge's σ floor, as a variance that grows with the ground the step covered: scan-to-map drift
        comes from new map content, so it adds up per metre (and per radian turned), not per scan."""
        fe = self.config.frontend
        if fe.sigma_floor_length is None:
            return self._edge_floor
        covered = math.hypot(rel[0], rel[1]) + fe.sigma_floor_m_per_rad * abs(rel[2])
        return self._edge_floor * max(covered / fe.sigma_floor_length, fe.sigma_floor_min_share)

    def _step_cov(self, delta: se2.PoseTuple) -> np.ndarray:
        """Odometry σ of one step: a floor plus a share of the motion (the odometry's trust)."""
        fe = self.config.frontend
        dist, turn = math.hypot(delta[0], delta[1]), abs(delta[2])
        sxy = fe.odom_step_sigma_xy + fe.odom_step_sigma_per_m * dist
        syaw = fe.odom_step_sigma_yaw + fe.odom_step_sigma_per_rad * turn + fe.odom_step_sigma_yaw_per_m * dist
        return np.diag([sxy ** 2, sxy ** 2, syaw ** 2])

    def _local_map(self, fill: bool = False) -> tuple[MatchGrid, IcpTarget] | None:
        """The recent scans at their current poses, rebuilt when the robot moved or the poses changed.
        `fill`: the match grid also covers the gaps between returns on one surface (`slam.surface_fill`),
        for the wide search of a step without odometry; ICP always sees the returns only."""
        fe = self.config.frontend
        n = len(self.poses)
        last = self.poses[-1]
        moved = se2_between(self._local_pose, last)
        stale = (self._local is None or self._local_at < 0 or math.hypot(moved[0], moved[1]) > 0.1
                 or abs(moved[2]) > 0.05 or fill != self._local_filled)
        if not stale and self._local is not None:
            return self._local
        lo = max(bisect.bisect_left(self.path, self.path[-1] - fe.local_map_distance) - 1, 0)  # O(window), not O(n)
        path = np.array(self.path[lo:])
        idx = lo + np.nonzero(path >= path[-1] - fe.local_map_distance)[0]
        if fe.local_map_min_log_odds is not None:
            # the first scan of every path bucket: a choice that stays put as the window slides, so each scan
            # is ray-cast into the evidence once when it enters and once when it leaves
            span = fe.local_map_distance / max(fe.local_map_scans - 1, 1)
            bucket = np.floor(path[idx - lo] / span).astype(np.int64)
            idx = idx[np.unique(bucket, return_index=True)[1]]
        if len(idx) > fe.local_map_scans:
            idx = idx[np.linspace(0, len(idx) - 1, fe.local_map_scans).astype(int)]
        pts = np.vstack([se2.transform_points(self.poses[k], self.points[k]) for k in idx])
        if len(pts) < 10:
            self._local = None
            return None
        pts = thin(pts, fe.resolution / 2)
        if fe.local_map_min_log_odds is not None:  # drop what the window's scans saw through
            self._evidence.sync(idx, self.poses, self.points)
            seen = pts[self._evidence.log_odds(pts) > fe.local_map_min_log_odds]
            pts = seen if len(seen) >= 10 else pts
        grid_pts = pts
        if fill:
            grid_pts = thin(np.vstack([pts] + [se2.transform_points(self.poses[k], self._filled_points(int(k), idx))
                                               for k in idx]), fe.resolution / 2)
        margin = 1.5 + 2 * fe.wide_window_xy if fill else 1.0  # wide: a zero margin the window fits in (csm)
        self._local_pts, self._local_idx = grid_pts, idx
        self._local = (MatchGrid(grid_pts, fe.resolution, fe.sigma, margin=margin), IcpTarget.from_points(pts))
        self._local_at, self._local_pose, self._local_filled = n - 1, last, fill
        self.stats.local_map_builds += 1
        return self._local

    def _filled_points(self, k: int, window: np.ndarray) -> np.ndarray:
        """Node k's returns with their same-surface gaps filled (base frame; `slam.surface_fill`), kept while k
        is in the local map's window: a node's returns never change, and it stays in ~30 windows."""
        if k not in self._filled:
            if len(self._filled) > 4 * len(window):  # drop the nodes that left the window
                keep = set(window.tolist())
                self._filled = {j: v for j, v in self._filled.items() if j in keep}
            fe, mp = self.config.frontend, self.config.motion_prior
            self._filled[k] = fill_surfaces(self.points[k], fe.resolution / 2, mp.fill_ratio, mp.fill_max_gap)
        return self._filled[k]

    @property
    def deskew_delay(self) -> float:
        """The odd beams' delay after the even ones learnt by `slam.deskew`, s (0: scans left as they are)."""
        return self._deskew.delay() if self._deskew is not None else 0.0

    def invalidate_local_map(self) -> None:
        self._local_at = -1

    def refresh_poses(self) -> None:
        """Take the graph's optimised estimate (after a loop closure)."""
        est = self.graph.poses()
        self.poses = [(float(p[0]), float(p[1]), float(p[2])) for p in est]
        self.invalidate_local_map()

    # ---- results -------------------------------------------------------------------------------------

    def finish(self) -> None:
        """Converge iSAM2, densify (`slam.densify`), then (config.final_batch) one Levenberg-Marquardt pass over
        the whole graph."""
        c0 = time.process_time()
        self.loops.flush()  # closures still deferred (`slam.loop_batch`) are optimised and checked
        self.graph.converge()
        if self.config.densify.enabled and self.config.loops.enabled:
            self.refresh_poses()
            self.densifier.run()
        if self.config.final_batch and self.loops.accepted:
            self.graph.batch_optimize()
        self.refresh_poses()
        self.stats.finish_cpu = time.process_time() - c0

    def trajectory(self) -> tuple[np.ndarray, np.ndarray]:
        return np.array(self.stamps), np.array(self.poses)

    def odometry_trajectory(self) -> np.ndarray:
        """The odometry used, placed at the first pose (a missing step counts as no motion)."""
        out = [self._start]
        for a, b in zip(self.odometry[:-1], self.odometry[1:], strict=True):
            d = se2_between(a, b) if a is not None and b is not None else (0.0, 0.0, 0.0)
            out.append(se2_compose(out[-1], d))
        return np.array(out[: len(self.poses)])

    def map(self, poses: np.ndarray | None = None) -> OccupancyGrid:
        """Occupancy grid from every scan that moved enough since the last integrated one (`slam.log_stats`)."""
        return scan_map(np.asarray(self.poses if poses is None else poses), self.points, self.config)
