"""Sensor health against streams whose rate, gaps, latency and noise are injected exactly."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.errors import FleetError
from sim.perception import SensorHealthMonitor, StreamConfig, StreamMonitor
from sim.robot_spec import RobotSpec
from sim.types import LidarScan


def _feed(mon: StreamMonitor, t0: float, t1: float, rate: float, rng: np.random.Generator | None = None,
          sigma: float = 0.0, latency: float = 0.0) -> float:
    """Readings every 1/rate s in [t0, t1); values: a fixed 50-beam 'scan' plus white noise σ."""
    base = np.linspace(1.0, 5.0, 50)
    t = t0
    n = 0
    while t < t1 - 1e-9:
        vals = base + (rng.normal(0, sigma, 50) if rng is not None and sigma > 0 else 0.0)
        mon.observe(t, t + latency, vals)
        n += 1
        t = t0 + n / rate
    return t


def test_a_nominal_stream_is_healthy() -> None:
    mon = StreamMonitor("r1/scan", rate_hz=10.0, nominal_noise=0.01)
    _feed(mon, 0.0, 5.0, 10.0, np.random.default_rng(0), sigma=0.01)
    h = mon.report(4.95)
    assert h.measured_hz == pytest.approx(10.0, rel=0.01)
    assert h.ok and h.dropouts == 0 and h.quality > 0.9
    assert h.noise_std == pytest.approx(0.01, rel=0.1)


def test_an_injected_dropout_is_flagged_within_one_second_of_sim_time() -> None:
    mon = StreamMonitor("r1/scan", rate_hz=10.0)
    last = _feed(mon, 0.0, 5.0, 10.0) - 0.1  # the last reading is at t = 4.9; then silence
    flagged_at = None
    for k in range(1, 300):
        now = last + 0.01 * k
        kinds = {a.kind for a in mon.report(now).alerts}
        if "dropout" in kinds:
            flagged_at = now
            break
    assert flagged_at is not None and flagged_at - last <= 1.0
    assert flagged_at - last > 0.3 - 1e-9  # not before the gap exceeds 3 periods
    h = mon.report(flagged_at)
    assert h.quality == 0.0 and h.dropouts == 1


def test_a_stream_that_resumes_reports_the_gap_and_recovers() -> None:
    mon = StreamMonitor("r1/imu", rate_hz=100.0, window_s=2.0)
    _feed(mon, 0.0, 3.0, 100.0)
    _feed(mon, 4.5, 5.0, 100.0)  # a 1.51 s hole
    h = mon.report(4.995)
    assert h.dropouts == 1 and h.longest_gap == pytest.approx(1.51, abs=1e-6)
    assert h.measured_hz == pytest.approx(50 / 2.0, rel=1e-6)  # the gap + 49 periods: 50 intervals, 2 s
    assert h.quality == pytest.approx(0.5 * 25 / 100)  # rate ratio, halved by the dropout in the window
    assert [a.kind for a in h.alerts] == ["rate_low"]
    _feed(mon, 5.0, 10.0, 100.0)
    assert mon.report(9.99).quality == pytest.approx(1.0, abs=0.01)  # the gap has left the window
    assert mon.report(9.99).dropouts == 1  # but the count is kept


def test_low_rate_latency_and_noise_raise_alerts() -> None:
    slow = StreamMonitor("s", rate_hz=10.0)
    _feed(slow, 0.0, 4.0, 5.0)  # half rate, gaps of 0.2 s (< 3 periods: not a dropout)
    h = slow.report(3.9)
    assert h.measured_hz == pytest.approx(5.0, rel=0.02)
    assert [a.kind for a in h.alerts] == ["rate_low"] and h.quality == pytest.approx(0.5, abs=0.02)
    late = StreamMonitor("l", rate_hz=10.0, max_latency=0.05)
    _feed(late, 0.0, 3.0, 10.0, latency=0.2)
    assert [a.kind for a in late.report(2.95).alerts] == ["latency"]
    assert late.report(2.95).latency_mean == pytest.approx(0.2)
    noisy = StreamMonitor("n", rate_hz=10.0, nominal_noise=0.01)
    _feed(noisy, 0.0, 3.0, 10.0, np.random.default_rng(1), sigma=0.03)  # noise_scale 3
    h = noisy.report(2.95)
    assert [a.kind for a in h.alerts] == ["noise"]
    assert h.noise_std == pytest.approx(0.03, rel=0.1) and h.quality == pytest.approx(1 / 3, rel=0.12)


def test_monitor_over_robot_readings_uses_the_robot_spec() -> None:
    spec = RobotSpec()
    mon = SensorHealthMonitor()
    mon.add_robot("r1", spec)
    assert mon.streams() == ["r1/imu", "r1/odom", "r1/scan"]
    rng = np.random.default_rng(2)
    truth = np.linspace(1.0, 6.0, 360)
    for k in range(30):  # 3 s of a stationary 10 Hz lidar with the spec's noise
        r = truth + rng.normal(0, spec.sensors.lidar.noise_std, 360)
        assert mon.observe(LidarScan("r1", 0.1 * k, -math.pi, 2 * math.pi / 360, 0.1, 10.0, r), 0.1 * k)
    assert not mon.observe(LidarScan("r2", 0.0, -math.pi, 1.0, 0.1, 10.0, truth))  # not monitored
    rep = mon.report(2.95)
    assert rep["r1/scan"].ok and rep["r1/scan"].noise_std == pytest.approx(0.01, rel=0.1)
    assert {a.kind for a in mon.alerts(2.95)} == {"no_data"}  # imu and odom never arrived
    with pytest.raises(FleetError, match="known streams"):
        mon.report(1.0, stream="r1/camera")
    with pytest.raises(FleetError):
        mon.add_stream("r1/scan", StreamConfig(rate_hz=10.0))
