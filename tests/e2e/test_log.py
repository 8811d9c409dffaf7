"""`fleetnav log`: every sensor stream to CSV, rows at the sensors' rates, statistics that match the data."""

from __future__ import annotations

import csv
import math
import subprocess

import numpy as np
import pytest

from tests.e2e.served_world import cli, env, served_world

pytest.importorskip("zenoh")

DURATION = 2.0  # sim s


def _read(path):
    with path.open(encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    return rows


def test_logger_writes_csvs_whose_rows_match_the_sensor_rates(tmp_path):
    with served_world(speed=2.0) as world:
        svc = world.service
        spec = svc.world.robot_spec("r1")
        svc.drive("r1", 0.3, 0.5, duration=60.0)  # a circle, so the logged values change
        done = subprocess.run(cli("log", "r1", "--out", str(tmp_path), "--connect", world.endpoint,
                                  "--duration", str(DURATION)), env=env(), capture_output=True, text=True,
                              timeout=60)
    assert done.returncode == 0, done.stderr + done.stdout
    rates = {"odom": spec.sensors.odometry.rate_hz, "imu": spec.sensors.imu.rate_hz,
             "scan": spec.sensors.lidar.rate_hz, "pose": svc.config.control_hz}
    for stream, rate in rates.items():
        rows = _read(tmp_path / f"{stream}.csv")
        stamps = np.array([float(r["stamp"]) for r in rows])
        # a half-open window of DURATION s: rate·DURATION rows, one fewer if the stream's phase starts late
        assert rate * DURATION - 1 <= len(rows) <= rate * DURATION, stream
        assert np.allclose(np.diff(stamps), 1.0 / rate, atol=1e-6), f"{stream}: a message was lost or doubled"
    scan = _read(tmp_path / "scan.csv")[0]
    beams = [float(scan[f"r{i}"]) for i in range(spec.sensors.lidar.beams)]
    finite = [b for b in beams if math.isfinite(b)]
    assert int(scan["returns"]) == len(finite)
    # the statistics printed and written are those of the CSV columns
    odom = _read(tmp_path / "odom.csv")
    v = np.array([float(r["v"]) for r in odom])
    stats = {(r["channel"], r["field"]): r for r in _read(tmp_path / "stats.csv")}
    assert float(stats[("odom", "v")]["mean"]) == pytest.approx(v.mean())
    assert float(stats[("odom", "v")]["max"]) == pytest.approx(v.max())
    assert float(stats[("imu", "gz")]["mean"]) == pytest.approx(0.5, abs=0.05)  # the yaw rate
    assert v.mean() == pytest.approx(0.3, abs=0.03)  # the commanded speed, through noisy wheel odometry
    assert float(stats[("pose", "x")]["rate_hz"]) == pytest.approx(svc.config.control_hz)
    assert "rate Hz" in done.stdout and "odom" in done.stdout
