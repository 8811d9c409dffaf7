"""FleetService operations for SLAM and localisation on live robots: start/stop a robot's SLAM, status with
ATE against ground truth, save/load maps through the workspace, localise in a known map, quality.

Each session listens to its robot's scans on the sim thread (`World.subscribe`) and feeds them, with the
wheel odometry, to a `slam.SlamPipeline` or `slam.Localizer`. The ground-truth pose is recorded at every
scan so the trajectory error is measured, never estimated. Sessions belong to one world: a reset or a new
world drops them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from pydantic import ValidationError

from fleet.core import ServiceCore
from planning.grid import OccupancyGrid
from planning.map_io import load_map, save_map
from sim.errors import ErrorCode, FleetError
from sim.types import LidarScan, Pose2D

if TYPE_CHECKING:  # slam (GTSAM, KISS-ICP) is imported when a session starts, not with the service
    from slam import LocalizationEstimate, Localizer, SlamPipeline


@dataclass
class SlamSession:
    robot: str
    pipeline: SlamPipeline
    started: float
    unsubscribe: Callable[[], None] | None
    truth: list[tuple[float, float, float]] = field(default_factory=list)  # ground truth at each scan

    @property
    def running(self) -> bool:
        return self.unsubscribe is not None


@dataclass
class LocSession:
    robot: str
    map_name: str
    localizer: Localizer
    started: float
    unsubscribe: Callable[[], None] | None
    estimate: LocalizationEstimate | None = None
    truth: Pose2D | None = None  # ground truth at the last update
    updates: int = 0


class SlamOps(ServiceCore):
    """Mixed into FleetService."""

    def _init_slam_ops(self) -> None:
        self._slam: dict[str, SlamSession] = {}
        self._loc: dict[str, LocSession] = {}
        self._maps: dict[str, OccupancyGrid] = {}

    # ---- SLAM ---------------------------------------------------------------------------------------

    def start_slam(self, robot: str, config: dict[str, Any] | None = None) -> dict[str, Any]:
        """Start online SLAM on `robot` (map frame = the world frame: the pipeline starts at the true pose).
        Restarting replaces the previous session of that robot."""
        from slam import SlamConfig, SlamPipeline

        cfg = _validated(SlamConfig, config or {}, "slam")

        def do() -> dict[str, Any]:
            self.registry.get(robot)
            self._stop_session(robot)
            spec = self.world.robot_spec(robot)
            if config is None or "lidar_offset" not in config:
                cfg.lidar_offset = (spec.mast.x_offset, 0.0, 0.0)
            pipe = SlamPipeline(cfg, robot=robot, initial_pose=self.world.robot_pose(robot))
            session = SlamSession(robot, pipe, self.world.time, None)
            session.unsubscribe = self.world.subscribe(lambda r: self._on_slam_scan(session, r), kinds=("scan",))
            self._slam[robot] = session
            self.events.publish(self.world.time, "slam_started", (robot,), f"SLAM started on {robot}")
            return self._slam_dict(session)

        return self.call(do)

    def _on_slam_scan(self, s: SlamSession, scan: Any) -> None:
        if not isinstance(scan, LidarScan) or scan.robot != s.robot or not self.world.table.has(s.robot):
            return
        s.pipeline.process_scan(scan, self.world.latest_odometry(s.robot))
        s.truth.append(self.world.robot_pose(s.robot).as_tuple())

    def stop_slam(self, robot: str) -> dict[str, Any]:
        """Stop feeding scans; the map and trajectory stay available (status, save_map)."""

        def do() -> dict[str, Any]:
            s = self._slam_session(robot)
            self._stop_session(robot)
            self.events.publish(self.world.time, "slam_stopped", (robot,), f"SLAM stopped on {robot}")
            return self._slam_dict(s)

        return self.call(do)

    def _stop_session(self, robot: str) -> None:
        s = self._slam.get(robot)
        if s is not None and s.unsubscribe is not None:
            s.unsubscribe()
            s.unsubscribe = None

    def slam_status(self, robot: str) -> dict[str, Any]:
        """Scans, keyframes, estimated pose, loop closures, and the trajectory error against ground truth."""
        return self.call(lambda: self._slam_dict(self._slam_session(robot), detail=True))

    def slam_trajectory(self, robot: str) -> tuple[np.ndarray, np.ndarray]:
        """(estimated (n, 3), ground truth (n, 3)) poses at every processed scan."""

        def do() -> tuple[np.ndarray, np.ndarray]:
            s = self._slam_session(robot)
            _, est = s.pipeline.trajectory()
            return est, np.array(s.truth, dtype=float).reshape(-1, 3)

        return self.call(do)

    def slam_map(self, robot: str) -> OccupancyGrid:
        return self.call(lambda: self._slam_session(robot).pipeline.map())

    def save_slam_map(self, robot: str, path: str) -> dict[str, Any]:
        """Write the robot's SLAM map as a ROS map_server PGM + YAML pair inside the workspace."""
        target = self._yaml_path(path, write=True)

        def do() -> dict[str, Any]:
            grid = self._slam_session(robot).pipeline.map()
            target.parent.mkdir(parents=True, exist_ok=True)
            save_map(grid, target)
            self._maps[target.stem] = grid
            return {"path": str(target), "name": target.stem, **_grid_meta(grid)}

        return self.call(do)

    def _slam_session(self, robot: str) -> SlamSession:
        if robot not in self._slam:
            self.registry.get(robot)  # unknown robot → the error lists the robots
            raise FleetError(ErrorCode.NOT_FOUND, f"no SLAM session on '{robot}'", "call start_slam first")
        return self._slam[robot]

    def _slam_dict(self, s: SlamSession, detail: bool = False) -> dict[str, Any]:
        st = s.pipeline.status()
        d: dict[str, Any] = {"robot": s.robot, "running": s.running, "started": s.started, "scans": st.scans,
                             "keyframes": st.keyframes, "pose": _pose(st.pose),
                             "loop_closures_accepted": st.loop_closures_accepted,
                             "loop_closures_rejected": st.loop_closures_rejected}
        if not detail:
            return d
        truth = np.array(s.truth, dtype=float).reshape(-1, 3)
        d["truth_pose"] = _pose(Pose2D(*truth[-1])) if len(truth) else None
        d["pose_error_m"] = (round(math.hypot(st.pose.x - truth[-1, 0], st.pose.y - truth[-1, 1]), 4)
                             if len(truth) else None)
        if len(truth) >= 2:
            from slam import trajectory_errors

            _, est = s.pipeline.trajectory()
            err = trajectory_errors(est, truth, align=False)  # map frame = world frame: no alignment needed
            d["ate"] = {"rmse_m": round(err.ate_rmse, 4), "mean_m": round(err.ate_mean, 4),
                        "max_m": round(err.ate_max, 4), "rpe_trans_rmse_m": round(err.rpe_trans_rmse, 4),
                        "rpe_rot_rmse_rad": round(err.rpe_rot_rmse, 5), "poses": err.count}
        else:
            d["ate"] = None
        d["loop_closures"] = [{"source": c.source, "target": c.target, "accepted": c.accepted, "reason": c.reason,
                               "rmse": round(c.rmse, 4)} for c in s.pipeline.loop_closures[-20:]]
        d["rejection_reasons"] = st.rejection_reasons
        d["map"] = {"width": st.map_width, "height": st.map_height, "current": st.map_current}
        d["processing_s"] = round(st.processing_time, 4)
        d["scan_time_s"] = round(st.scan_time, 3)
        return d

    # ---- maps and localisation ----------------------------------------------------------------------

    def load_slam_map(self, path: str, name: str | None = None) -> dict[str, Any]:
        """Load a map_server YAML (inside the workspace) under `name` (default: the file's stem)."""
        src = self._yaml_path(path, write=False)
        if not src.is_file():
            raise FleetError(ErrorCode.NOT_FOUND, f"no map file '{path}'", "save one with save_slam_map first")
        grid = load_map(src)
        key = name or src.stem
        self.call(lambda: self._maps.__setitem__(key, grid))
        return {"name": key, "path": str(src), **_grid_meta(grid)}

    def list_maps(self) -> list[dict[str, Any]]:
        return self.call(lambda: [{"name": n, **_grid_meta(g)} for n, g in self._maps.items()])

    def map_grid(self, name: str) -> OccupancyGrid:
        def do() -> OccupancyGrid:
            if name not in self._maps:
                raise FleetError(ErrorCode.NOT_FOUND, f"no map '{name}'",
                                 f"maps: {', '.join(self._maps) or 'none'}; load one with load_slam_map")
            return self._maps[name]

        return self.call(do)

    def localize(self, robot: str, map_name: str, initial: Pose2D | None = None, *, sigma_xy: float = 0.25,
                 sigma_yaw: float = 0.2, config: dict[str, Any] | None = None) -> dict[str, Any]:
        """Localise `robot` in a loaded map: around `initial`, or globally (initial=None). It then updates on
        every scan; read the estimate and its quality with localization_status."""
        from slam import LocalizationConfig, Localizer

        cfg = _validated(LocalizationConfig, config or {}, "localization")
        if not (math.isfinite(sigma_xy) and sigma_xy > 0 and math.isfinite(sigma_yaw) and sigma_yaw > 0):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, "sigma_xy and sigma_yaw must be > 0")

        def do() -> dict[str, Any]:
            self.registry.get(robot)
            grid = self.map_grid(map_name)
            self._stop_localizer(robot)
            spec = self.world.robot_spec(robot)
            loc = Localizer(grid, cfg, seed=int(self.world.rng.integers(2**31)),
                            lidar_offset=(spec.mast.x_offset, 0.0, 0.0), max_range=spec.sensors.lidar.range_max)
            loc.initialize(initial, sigma_xy, sigma_yaw)
            s = LocSession(robot, map_name, loc, self.world.time, None)
            s.unsubscribe = self.world.subscribe(lambda r: self._on_loc_scan(s, r), kinds=("scan",))
            self._loc[robot] = s
            return self._loc_dict(s)

        return self.call(do)

    def _on_loc_scan(self, s: LocSession, scan: Any) -> None:
        if not isinstance(scan, LidarScan) or scan.robot != s.robot or not self.world.table.has(s.robot):
            return
        s.estimate = s.localizer.update(scan, self.world.latest_odometry(s.robot))
        s.truth = self.world.robot_pose(s.robot)
        s.updates += 1

    def _stop_localizer(self, robot: str) -> None:
        s = self._loc.pop(robot, None)
        if s is not None and s.unsubscribe is not None:
            s.unsubscribe()

    def stop_localization(self, robot: str) -> dict[str, Any]:
        def do() -> dict[str, Any]:
            d = self._loc_dict(self._loc_session(robot))
            self._stop_localizer(robot)
            return d | {"running": False}

        return self.call(do)

    def localization_status(self, robot: str) -> dict[str, Any]:
        """The estimate, its quality (particle spread, match score, ambiguity) and its error vs ground truth."""
        return self.call(lambda: self._loc_dict(self._loc_session(robot)))

    def _loc_session(self, robot: str) -> LocSession:
        if robot not in self._loc:
            self.registry.get(robot)
            raise FleetError(ErrorCode.NOT_FOUND, f"'{robot}' is not localising", "call localize first")
        return self._loc[robot]

    def _loc_dict(self, s: LocSession) -> dict[str, Any]:
        d: dict[str, Any] = {"robot": s.robot, "map": s.map_name, "running": s.unsubscribe is not None,
                             "started": s.started, "updates": s.updates}
        e = s.estimate
        if e is None:
            return d | {"pose": None, "quality": None, "error_m": None}
        q = e.quality
        d["pose"] = _pose(e.pose)
        d["quality"] = {"spread_xy_m": round(q.spread_xy, 4), "spread_yaw_rad": round(q.spread_yaw, 4),
                        "match_score": round(q.match_score, 3), "ambiguity": round(q.ambiguity, 3),
                        "particles": q.particles, "converged": q.converged, "icp_refined": e.refined}
        if s.truth is not None:
            d["truth_pose"] = _pose(s.truth)
            d["error_m"] = round(e.pose.distance_to(s.truth), 4)
            d["yaw_error_rad"] = round(abs(math.remainder(e.pose.yaw - s.truth.yaw, 2 * math.pi)), 4)
        return d

    # ---- SLAM on a recorded log ----------------------------------------------------------------------

    def run_slam_on_log(self, path: str, out: str | None = None, odometry: str = "odom_increments",
                        config: dict[str, Any] | None = None) -> dict[str, Any]:
        """Run `slam.log_run` on a CARMEN (.log/.log.gz) or MCAP log inside the workspace; outputs go to `out`
        (default: `slam/<log name>/` in the outputs area). Independent of the sim: call it off the sim thread."""
        from slam.log_config import LogSlamConfig
        from slam.log_run import run_log

        src = self.workspace.read(path, "log file")
        stem = src.name.split(".")[0]
        cfg = _validated(LogSlamConfig, {**(config or {}), "odometry": odometry}, "log slam")
        dst = self.workspace.write_folder(out if out else f"slam/{stem}")
        try:
            report = run_log(src, dst, cfg)
        finally:
            self.workspace.remember_tree(dst)
        report["out"] = str(dst)
        report["loop_closures"]["list"] = report["loop_closures"]["list"][-20:]  # the latest; all in report.json
        return report

    def _yaml_path(self, path: str, *, write: bool) -> Path:
        p = self.workspace.resolve(path, write=write)
        if p.suffix not in (".yaml", ".yml"):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"a map path ends in .yaml, got '{path}'",
                             "e.g. maps/arena.yaml (the PGM is written next to it)")
        return p


def _validated(model: Any, data: dict[str, Any], section: str) -> Any:
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first["loc"])
        raise FleetError(ErrorCode.INVALID_CONFIG, f"{section} settings: {where}: {first['msg']}",
                         f"fields: {', '.join(model.model_fields)}") from exc


def _pose(p: Pose2D) -> dict[str, float]:
    return {"x": round(float(p.x), 4), "y": round(float(p.y), 4), "yaw": round(float(p.yaw), 4)}


def _grid_meta(g: OccupancyGrid) -> dict[str, Any]:
    return {"width": g.width, "height": g.height, "resolution": g.resolution,
            "origin": [round(float(v), 4) for v in g.origin[:2]], "occupied_cells": int(g.occupied().sum()),
            "free_cells": int(g.free().sum()), "unknown_cells": int(g.unknown().sum())}
