"""Interlaced-scan deskewing (slam.deskew) against ground truth: scans whose odd beams are cast from the pose the
robot reaches T later, as a SICK at 0.5° builds them from two mirror sweeps."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from sim.types import LidarScan, Pose2D
from slam import se2
from slam.deskew import DeskewConfig, InterlaceDeskew
from slam.icp import IcpTarget, icp
from slam.io_carmen import format_flaser, read_carmen
from slam.log_config import LogSlamConfig
from slam.log_slam import LogSlam
from tests.slam import synth

T = 0.014  # s: the odd sweep comes this long after the even one


def _interlaced(segs: np.ndarray, pose: Pose2D, v: float, omega: float, delay: float, rng: np.random.Generator
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(points, ranges, odd) of one 720-beam scan: even beams from `pose`, odd beams from the pose `delay` later."""
    later = se2.transform_points(pose.as_tuple(), np.array([[v * delay, 0.0]]))[0]
    late = Pose2D(float(later[0]), float(later[1]), pose.yaw + omega * delay)
    r0 = synth.raycast(segs, pose, beams=720, noise=0.005, rng=rng)
    r1 = synth.raycast(segs, late, beams=720, noise=0.005, rng=rng)
    ranges = r0.ranges.copy()
    ranges[1::2] = r1.ranges[1::2]  # beam k of the later scan is at the same angle in *its* frame
    ang = r0.angles()
    ok = np.isfinite(ranges)
    pts = np.column_stack([ranges[ok] * np.cos(ang[ok]), ranges[ok] * np.sin(ang[ok])])
    return pts, ranges[ok], (np.nonzero(ok)[0] % 2) == 1


def _mid(pose: Pose2D, v: float, omega: float, delay: float) -> Pose2D:
    """The pose midway between the two sweeps (the frame deskewed scans are put in)."""
    p = se2.transform_points(pose.as_tuple(), np.array([[v * delay / 2, 0.0]]))[0]
    return Pose2D(float(p[0]), float(p[1]), pose.yaw + omega * delay / 2)


def _calibrated(delay: float) -> InterlaceDeskew:
    segs, rng = synth.room(), np.random.default_rng(7)
    d = InterlaceDeskew(DeskewConfig(enabled=True, min_samples=20))
    for k in range(30):
        pose = Pose2D(6.0 + 0.2 * (k % 7), 4.0 + 0.1 * (k % 5), 0.3 * k)
        omega = (0.3 + 0.05 * (k % 6)) * (1 if k % 2 else -1)
        pts, ranges, odd = _interlaced(segs, pose, 0.4, omega, delay, rng)
        d.observe(pts, ranges, odd, omega)
    return d


def test_the_delay_is_estimated_from_the_scans_and_deskewing_removes_the_blur() -> None:
    d = _calibrated(T)
    assert d.samples == 30
    assert abs(d.delay() - T) < 0.15 * T
    segs, rng = synth.room(), np.random.default_rng(11)
    pose, v, omega = Pose2D(9.0, 5.5, 0.7), 0.5, 0.6  # a fast turn: the halves are 0.48° apart
    pts, _, odd = _interlaced(segs, pose, v, omega, T, rng)
    truth = synth.raycast(segs, _mid(pose, v, omega, T), beams=2880).points()  # midway, noise-free
    target = IcpTarget.from_points(truth)

    def wall_offset(p: np.ndarray) -> float:  # RMS distance of the points to the true surfaces seen midway
        dist, _ = target.tree.query(p)
        return float(np.sqrt(np.mean(np.minimum(dist, 0.2) ** 2)))

    fixed = d.apply(pts, odd, (v, 0.0, omega))
    assert wall_offset(fixed) < 0.5 * wall_offset(pts)
    rmse = []
    for p in (pts, fixed):
        fit = icp(p, target, (0.01, -0.01, 0.005), max_correspondence=0.15, inlier_distance=0.15)
        assert abs(fit.pose[2]) < 1e-3  # the blurred scan's heading is the midway one too: blur, not bias
        rmse.append(fit.rmse)
    assert rmse[1] < 0.6 * rmse[0]  # but it fits the walls much more tightly


def test_a_scan_from_one_sweep_is_left_alone() -> None:
    d = _calibrated(0.0)
    assert d.delay() == 0.0
    pts = np.array([[1.0, 0.0], [2.0, 1.0], [3.0, -1.0]])
    assert np.array_equal(d.apply(pts, np.array([False, True, True]), (0.5, 0.0, 0.8)), pts)


def test_log_slam_deskews_by_default_and_the_option_turns_it_off() -> None:
    on = LogSlam(LogSlamConfig())
    assert on._deskew is not None and math.isclose(on._deskew.config.min_rate, 0.1)
    assert LogSlam(LogSlamConfig.model_validate({"frontend": {"deskew": {"enabled": False}}}))._deskew is None


def test_log_slam_learns_the_delay_from_its_odometry_and_deskews_the_stored_scans() -> None:
    """LogSlam fed interlaced scans (odd beams cast 14 ms later) and exact odometry, its turn rate swinging
    smoothly between ±0.6 rad/s: the delay is learnt from the odometry's turn rate (the step before the scan: it
    lags a little, hence 20 %), and the last scan's stored points lie on the walls as seen midway between the
    sweeps (uncorrected, each half is 0.25° off that: 2 cm at 5 m)."""
    segs, rng, dt, v = synth.room(), np.random.default_rng(5), 0.2, 0.3
    slam = LogSlam(LogSlamConfig.model_validate({"loops": {"enabled": False},
                                                 "frontend": {"deskew": {"min_samples": 15}}}))
    pose = Pose2D(7.5, 4.5, 0.0)
    last = pose
    omega = 0.0
    for k in range(50):
        omega = 0.6 * math.sin(2 * math.pi * k / 40)  # the last scan turns at 0.59 rad/s
        r0 = synth.raycast(segs, pose, beams=720, noise=0.005, rng=rng, stamp=k * dt)
        later = se2.transform_points(pose.as_tuple(), np.array([[v * T, 0.0]]))[0]
        r1 = synth.raycast(segs, Pose2D(float(later[0]), float(later[1]), pose.yaw + omega * T), beams=720,
                           noise=0.005, rng=rng)
        ranges = r0.ranges.copy()
        ranges[1::2] = r1.ranges[1::2]
        slam.add_scan(replace(r0, ranges=ranges), pose)
        last = pose
        nxt = se2.transform_points(pose.as_tuple(), np.array([[v * dt, 0.0]]))[0]
        pose = Pose2D(float(nxt[0]), float(nxt[1]), pose.yaw + omega * dt)
    assert slam._deskew is not None and abs(slam._deskew.delay() - T) < 0.2 * T
    walls = IcpTarget.from_points(synth.raycast(segs, _mid(last, v, omega, T), beams=2880).points())
    pts = slam.points[-1]
    near = np.hypot(*pts.T) < 8.0
    d, _ = walls.tree.query(pts[near])
    assert float(np.sqrt(np.mean(np.minimum(d, 0.2) ** 2))) < 0.0075  # 5 mm deskewed, 11 mm as recorded


def test_carmen_reader_gives_the_odometry_rate_at_each_scan(tmp_path: Path) -> None:
    """ODOM lines at 20 Hz on an arc (0.4 m/s, 0.5 rad/s), a FLASER line every second between two of them: the
    rate at each scan's stamp is the arc's (the chord of 0.05 s: vx within 0.1 %, vy = v·ω·dt/2)."""
    v, w, dt = 0.4, 0.5, 0.05
    lines = []
    for k in range(121):
        t = k * dt
        x, y = (v / w) * math.sin(w * t), (v / w) * (1 - math.cos(w * t))
        lines.append(f"ODOM {x:.9f} {y:.9f} {w * t:.9f} 0 0 0 {t:.6f} nohost {t:.6f}")
        if k % 20 == 10:
            ts = t + dt / 2
            scan = LidarScan("carmen", ts, -math.pi / 2, math.pi / 180, 0.1, 10.0, np.full(181, 3.0))
            lines.append(format_flaser(scan, Pose2D(x, y, w * t)))
    (tmp_path / "arc.log").write_text("\n".join(lines) + "\n")
    log = read_carmen(tmp_path / "arc.log")
    assert log.odom_rates is not None and log.odom_rates.shape == (6, 4)
    assert np.isnan(log.odom_rates[0]).all()  # the first scan has no previous one to count ODOM lines from
    rates = log.odom_rates[1:]
    assert np.allclose(rates[:, 3], dt)
    assert np.allclose(rates[:, 2], w, atol=1e-6)
    assert np.allclose(rates[:, 0], v, rtol=1e-3)
    assert np.allclose(rates[:, 1], v * w * dt / 2, atol=1e-4)
