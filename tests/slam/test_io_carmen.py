"""A small synthetic CARMEN log (written here) parses and maps."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from sim.errors import FleetError
from sim.types import LidarScan, Pose2D
from slam.io_carmen import format_flaser, read_carmen
from slam.metrics import map_iou, trajectory_errors
from slam.pipeline import SlamPipeline
from tests.slam import synth

SEGS = synth.room()
FOV = math.pi * 179 / 180  # 180 beams from −90° to +89°: first to last beam span 179°


def _flaser_scan(pose: Pose2D, rng: np.random.Generator, stamp: float) -> LidarScan:
    """180 beams over 180° from −90°, as FLASER lines hold them (max range 10 m written as 10.000)."""
    full = synth.raycast(SEGS, pose, beams=360, noise=0.01, rng=rng, stamp=stamp)
    r = full.ranges[90:270]  # beams −90° … +89°
    return LidarScan("carmen", stamp, -math.pi / 2, math.pi / 180, 0.1, 10.0, r)


def _write_log(path: Path, n: int) -> tuple[list[Pose2D], list[Pose2D]]:
    rng = np.random.default_rng(5)
    truth = synth.loop_path(n, 0.1)
    odom = synth.wheel_odometry(truth, rng)
    lines = ["# synthetic CARMEN log", "PARAM robot_front_laser_max 10.0 nohost 0.0"]
    for k, (p, o) in enumerate(zip(truth, odom, strict=True)):
        lines.append(f"ODOM {o.x:.6f} {o.y:.6f} {o.yaw:.6f} 0.8 0.0 0.0 {k * 0.1 - 0.05:.6f} nohost 0.0")
        lines.append(format_flaser(_flaser_scan(p, rng, k * 0.1), o))
    path.write_text("\n".join(lines) + "\n")
    return truth, odom


def test_carmen_log_parses(tmp_path: Path) -> None:
    truth, odom = _write_log(tmp_path / "room.log", 20)
    log = read_carmen(tmp_path / "room.log", max_range=10.0, flaser_fov=FOV, flaser_angle_min=-math.pi / 2,
                      odometry="laser_pose")
    assert len(log.records) == 20 and len(log.odometry) == 20 and log.skipped == {"PARAM": 1}
    rec = log.records[3]
    assert rec.scan.ranges.size == 180 and rec.scan.angle_min == pytest.approx(-math.pi / 2)
    assert rec.scan.angle_increment == pytest.approx(math.pi / 180)
    assert rec.scan.stamp == pytest.approx(0.3)
    assert rec.odom is not None and rec.odom.x == pytest.approx(odom[3].x, abs=1e-6)
    expected = synth.raycast(SEGS, truth[3]).ranges[90:270]  # noise-free beams −90° … +89°
    finite = np.isfinite(rec.scan.ranges)
    assert np.abs(rec.scan.ranges[finite] - expected[finite]).max() < 0.05  # 1 cm noise, 5 σ
    assert not np.isfinite(rec.scan.ranges[~finite]).any()  # 10.000 = max range = no return


def test_carmen_log_maps(tmp_path: Path) -> None:
    truth, odom = _write_log(tmp_path / "room.log", 420)
    log = read_carmen(tmp_path / "room.log", max_range=10.0, flaser_fov=FOV, flaser_angle_min=-math.pi / 2,
                      odometry="laser_pose")
    slam = SlamPipeline(initial_pose=truth[0])
    for rec in log.records:
        slam.process_scan(rec.scan, rec.odom)
    _, est = slam.trajectory()
    truth_xy = np.array([p.as_tuple() for p in truth])
    err = trajectory_errors(est, truth_xy)
    wheel = trajectory_errors(np.array([o.as_tuple() for o in odom]), truth_xy)
    assert err.ate_rmse < 0.05 and err.ate_rmse < wheel.ate_rmse / 10  # 42 m of 180° scans, no loop closed
    grid_truth = synth.ground_truth_grid(SEGS, 0.05, (-1.025, -1.025, 21.025, 15.025))
    assert map_iou(slam.map(), grid_truth).occupied > 0.85


def test_robotlaser1_line_and_errors(tmp_path: Path) -> None:
    ranges = " ".join(["2.5"] * 4)
    line = (f"ROBOTLASER1 0 -1.5708 3.1416 1.0472 8.0 0.01 0 4 {ranges} 0 "
            "1.1 2.0 0.5 1.0 2.0 0.5 0.3 0.0 0.2 0.1 0.0 12.5 host 12.5")
    (tmp_path / "a.log").write_text(line + "\n")
    log = read_carmen(tmp_path / "a.log", odometry="laser_pose")
    scan = log.records[0].scan
    assert scan.ranges.tolist() == [2.5] * 4 and scan.angle_increment == pytest.approx(1.0472)
    assert scan.stamp == 12.5 and log.records[0].odom == Pose2D(1.0, 2.0, 0.5)
    assert log.lidar_offset is not None
    np.testing.assert_allclose(log.lidar_offset, (0.1 * math.cos(0.5), -0.1 * math.sin(0.5), 0.0), atol=1e-9)
    (tmp_path / "bad.log").write_text("FLASER 3 1.0 2.0\n")
    with pytest.raises(FleetError, match=r"bad.log:1: malformed FLASER"):
        read_carmen(tmp_path / "bad.log")
