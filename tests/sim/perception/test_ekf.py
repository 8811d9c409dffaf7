"""The odometry/IMU EKF against ground truth: closed-form arcs, a slipping 100 m drive, pose updates."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.perception import Ekf, EkfConfig, estimate_imu_bias, make_ekf
from sim.types import ImuReading, OdometryReading, Pose2D
from tests.sim.perception.drive_sim import Drive, simulate


def _errors(drive: Drive, ekf_poses: list[Pose2D]) -> tuple[float, float]:
    """RMS position error of odometry alone and of the EKF against the truth."""
    odom = np.array([[o.pose.x, o.pose.y] for o in drive.odom])
    est = np.array([[p.x, p.y] for p in ekf_poses])
    truth = np.array([[p.x, p.y] for _, p in drive.truth])
    rms = lambda a: float(np.sqrt(np.mean(np.sum((a - truth) ** 2, axis=1))))  # noqa: E731
    return rms(odom), rms(est)


def _run(drive: Drive, ekf: Ekf, gyro_bias: float, differential: bool = False) -> list[Pose2D]:
    poses = []
    imu = iter(drive.imu)
    pending: ImuReading | None = next(imu)
    for o in drive.odom:
        while pending is not None and pending.stamp <= o.stamp:
            ekf.update_imu(pending, gyro_bias=gyro_bias)
            pending = next(imu, None)
        ekf.update_odometry(o, differential=differential)
        poses.append(ekf.state.pose)
    return poses


def test_constant_twist_traces_the_closed_form_circle() -> None:
    v, w = 0.8, 0.4  # radius v/ω = 2 m
    ekf = Ekf(odom_v_std=1e-3, odom_w_std=1e-3)
    for k in range(1, 501):  # 10 s at 50 Hz of perfect odometry
        t = 0.02 * k
        ekf.update_odometry(OdometryReading("r", t, Pose2D(), v, w, 0.0, 0.0))
    t = 10.0
    r = v / w
    expect = (r * math.sin(w * t), r * (1 - math.cos(w * t)), math.remainder(w * t, 2 * math.pi))
    s = ekf.state
    # The filter starts at v = ω = 0, so it lags the first update by one step (0.02 s): ≈ 2 cm of arc.
    assert (s.x, s.y) == pytest.approx(expect[:2], abs=0.03)
    assert s.yaw == pytest.approx(expect[2], abs=0.02)


def test_ekf_beats_wheel_odometry_on_a_slipping_100m_drive() -> None:
    drive = simulate(seed=4, duration=102.0, gyro_bias=0.01)
    still = [r for r in drive.imu if r.stamp <= 2.0]
    bias = estimate_imu_bias(still)
    assert bias.gyro[2] == pytest.approx(0.01, rel=0.1)
    ekf = make_ekf(EkfConfig(odom_w_std=0.1, gyro_std=0.005))
    odom_rms, ekf_rms = _errors(drive, _run(drive, ekf, bias.gyro[2]))
    travelled = sum(o.linear * 0.02 for o in drive.odom)
    assert travelled == pytest.approx(100.0, rel=0.02)
    assert odom_rms > 0.2  # heading drift from slip puts the odometry decimetres to metres off
    assert ekf_rms < 0.3 * odom_rms, (odom_rms, ekf_rms)


def test_differential_mode_matches_twist_mode() -> None:
    drive = simulate(seed=5, duration=30.0)
    bias = estimate_imu_bias([r for r in drive.imu if r.stamp <= 2.0]).gyro[2]
    a = _run(drive, Ekf(), bias)
    b = _run(drive, Ekf(), bias, differential=True)
    gap = max(p.distance_to(q) for p, q in zip(a, b, strict=True))
    assert gap < 0.05  # both read the same encoder motion


def test_an_unmodelled_gyro_bias_hurts_and_calibration_fixes_it() -> None:
    drive = simulate(seed=6, duration=62.0, gyro_bias=0.05)
    _, raw = _errors(drive, _run(drive, Ekf(gyro_std=0.005), 0.0))
    _, fixed = _errors(drive, _run(drive, Ekf(gyro_std=0.005), 0.05))
    assert fixed < 0.5 * raw


def test_absolute_pose_updates_bound_the_drift() -> None:
    drive = simulate(seed=7, duration=60.0, slip=0.05)
    ekf = Ekf()
    rng = np.random.default_rng(0)
    errs = []
    for k, (o, (t, truth)) in enumerate(zip(drive.odom, drive.truth, strict=True)):
        ekf.update_odometry(o)
        if k % 50 == 0:  # a scan-matching pose once a second, 5 cm / 1° noise
            noisy = Pose2D(truth.x + rng.normal(0, 0.05), truth.y + rng.normal(0, 0.05),
                           truth.yaw + rng.normal(0, math.radians(1)))
            ekf.update_pose(noisy, t)
        errs.append(ekf.state.pose.distance_to(truth))
    assert max(errs[100:]) < 0.3
    assert drive.odom[-1].pose.distance_to(drive.truth[-1][1]) > 2 * max(errs[-50:])
    cov = ekf.state.covariance
    assert np.allclose(cov, cov.T) and np.all(np.linalg.eigvalsh(cov) > 0)
