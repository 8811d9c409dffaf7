"""Online SLAM on a robot's own sensors during a mission, scored against ground truth (ATE, map IoU).

Each probe feeds its robot's lidar scans (with the wheel odometry of the moment) to a slam.SlamPipeline
as the world publishes them, and keeps the true pose at each scan's stamp. The map frame is anchored at
the robot's spawn pose, so the estimate and the truth share a frame; ATE is still computed after the
standard SE(2) alignment.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from sim.types import LidarScan
from slam import SlamConfig, SlamPipeline, map_iou, match_by_stamp, trajectory_errors

if TYPE_CHECKING:
    from fleet.service import FleetService


class SlamProbe:
    def __init__(self, svc: FleetService, robot: str, config: SlamConfig) -> None:
        self.svc, self.robot = svc, robot
        self.pipeline = SlamPipeline(config, robot=robot, initial_pose=svc.world.robot_pose(robot))
        self._truth: list[tuple[float, float, float, float]] = []
        self._unsubscribe = svc.world.subscribe(self._on_scan, kinds=("scan",))

    def _on_scan(self, reading: object) -> None:
        if not isinstance(reading, LidarScan) or reading.robot != self.robot:
            return
        w = self.svc.world
        if self.robot not in w.robot_names():
            return
        p = w.robot_pose(self.robot)
        self._truth.append((reading.stamp, p.x, p.y, p.yaw))
        self.pipeline.process_scan(reading, w.latest_odometry(self.robot))

    def close(self) -> None:
        self._unsubscribe()

    def result(self, out_dir: Path | None = None) -> dict[str, float]:
        """ATE/RPE of the optimised trajectory, map IoU against the world's grid; the map saved if asked."""
        self.close()
        stamps, est = self.pipeline.trajectory()
        truth = np.array(self._truth, dtype=float).reshape(-1, 4)
        st = self.pipeline.status()
        out: dict[str, float] = {"scans": float(st.scans), "keyframes": float(st.keyframes),
                                 "loop_closures": float(st.loop_closures_accepted), "poses": 0.0}
        if len(stamps) < 2 or len(truth) < 2:
            return out | {"ate_rmse": float("nan")}
        idx, gt = match_by_stamp(stamps, truth[:, 0], truth[:, 1:])
        if len(idx) < 2:
            return out | {"ate_rmse": float("nan")}
        err = trajectory_errors(est[idx], gt)
        grid = self.pipeline.map()
        iou = map_iou(grid, self.svc.static_grid())
        if out_dir is not None:
            self.pipeline.save_map(out_dir / f"slam_map_{self.robot}.yaml")
        return out | {"poses": float(len(idx)), "ate_rmse": err.ate_rmse, "ate_max": err.ate_max,
                      "rpe_trans_rmse": err.rpe_trans_rmse, "rpe_rot_rmse": err.rpe_rot_rmse,
                      "map_iou_occupied": iou.occupied, "map_iou_free": iou.free, "map_coverage": iou.coverage}
