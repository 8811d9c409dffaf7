"""What real Radish/CARMEN logs other than the development five contain: PARAM/SYNC/NEFF/TRUEPOS/SONAR/NMEA lines,
comments, Windows line endings, a last line cut off, ROBOTLASER1 with remissions, 180/181/361/401-beam FLASER,
logs without ODOM, raw (non-corrected) logs whose laser-line poses are the odometry, `.clf` files."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from fleetnav.cli import app
from sim.errors import FleetError
from sim.types import Pose2D
from slam.io_carmen import read_carmen
from slam.log_config import LogSlamConfig
from slam.log_run import load_log, run_log
from tests.slam import carmen_synth


def _flaser(n: int, pose: tuple[float, float, float], t: float) -> str:
    r = " ".join(f"{2.0 + 0.001 * k:.3f}" for k in range(n))
    x, y, th = pose
    return f"FLASER {n} {r} {x} {y} {th} {x} {y} {th} {t} host {t}"


def _odom(pose: tuple[float, float, float], t: float) -> str:
    return f"ODOM {pose[0]} {pose[1]} {pose[2]} 0.3 0.0 0.0 {t} host {t}"


def test_other_messages_comments_crlf_and_a_cut_off_last_line(tmp_path: Path) -> None:
    lines = ["# CARMEN Logfile", "# file format is one message per line", "#PARAM commented out",
             "PARAM robot_front_laser_max 50 nohost 0", "PARAM robot_frontlaser_offset 0.1 nohost 0",
             "PARAM laser_front_laser_type LMS nohost 0", "SYNC 1.0 host 1.0",
             _odom((0, 0, 0), 0.0), _flaser(180, (0, 0, 0), 0.0),
             "NEFF 12.5 host 0.0", "TRUEPOS 0.1 0.2 0.0 0 0 0 0.5 host 0.5",
             "SONAR 0.5 0.1 3 1.0 2.0 3.0 0.5 host 0.5", "NMEA-GGA 1 $GPGGA,123519,4807.038,N 0.6 host 0.6",
             "RAWLASER3 garbage that is not ours", _odom((0.5, 0, 0.1), 1.0), _flaser(180, (0.5, 0, 0.1), 1.0),
             "", "FLASER 180 1.0 1.0 1.0"]  # the logger was stopped mid-line
    (tmp_path / "a.log").write_bytes("\r\n".join(lines).encode() + b"\r\n")
    log = read_carmen(tmp_path / "a.log")
    assert len(log.records) == 2
    scan = log.records[1].scan
    assert scan.ranges.size == 180 and scan.ranges[7] == pytest.approx(2.007, abs=1e-12)
    assert scan.angle_increment == pytest.approx(math.radians(1.0)) and scan.stamp == 1.0
    assert log.records[1].odom is not None
    assert log.records[1].odom.as_tuple() == pytest.approx((0.5, 0.0, 0.1), abs=1e-12)
    assert log.skipped == {"PARAM": 3, "SYNC": 1, "NEFF": 1, "TRUEPOS": 1, "SONAR": 1, "NMEA-GGA": 1,
                           "RAWLASER3": 1, "truncated": 1}


def test_a_malformed_line_before_the_end_names_file_and_line(tmp_path: Path) -> None:
    lines = [_flaser(181, (0, 0, 0), 0.0), "FLASER 181 1.0 2.0", _flaser(181, (0, 0, 0), 1.0)]
    (tmp_path / "b.clf").write_text("\n".join(lines) + "\n")
    with pytest.raises(FleetError, match=r"b\.clf:2: malformed FLASER"):
        read_carmen(tmp_path / "b.clf")
    (tmp_path / "c.clf").write_text("\n".join([lines[0], lines[2]]) + "\n")  # .clf goes through load_log
    assert len(load_log(tmp_path / "c.clf", LogSlamConfig()).records) == 2


@pytest.mark.parametrize(("n", "step"), [(180, 1.0), (181, 1.0), (361, 0.5), (401, 180 / 400)])
def test_flaser_beam_counts(tmp_path: Path, n: int, step: float) -> None:
    (tmp_path / "d.log").write_text(_flaser(n, (0, 0, 0), 0.0) + "\n")
    scan = read_carmen(tmp_path / "d.log", odometry="none").records[0].scan
    assert scan.ranges.size == n and scan.angle_min == pytest.approx(-math.pi / 2)
    assert scan.angle_increment == pytest.approx(math.radians(step), abs=1e-12)
    assert scan.ranges[-1] == pytest.approx(2.0 + 0.001 * (n - 1), abs=1e-12)


def test_robotlaser1_with_remissions(tmp_path: Path) -> None:
    ranges = " ".join(f"{1.0 + 0.1 * k:.1f}" for k in range(5))
    line = (f"ROBOTLASER1 0 -0.5 1.0 0.25 20.0 0.01 1 5 {ranges} 5 10 20 30 40 50 "
            f"{1 + 0.1 * math.cos(0.3):.9f} {2 + 0.1 * math.sin(0.3):.9f} 0.3 1.0 2.0 0.3 0.2 0.0 0.5 0.5 0.0 "
            "7.25 host 7.25")  # the laser 0.1 m ahead of the robot
    (tmp_path / "e.log").write_text(line + "\n")
    log = read_carmen(tmp_path / "e.log", odometry="laser_pose")
    s = log.records[0].scan
    assert s.ranges.tolist() == pytest.approx([1.0, 1.1, 1.2, 1.3, 1.4]) and s.stamp == 7.25
    assert s.angle_min == -0.5 and s.angle_increment == 0.25
    assert log.reference is not None and log.reference[0].tolist() == [1.0, 2.0, 0.3]  # the robot, not the laser
    assert log.lidar_offset == pytest.approx((0.1, 0.0, 0.0), abs=1e-9)


def test_what_the_laser_poses_are(tmp_path: Path) -> None:
    p = tmp_path / "f.log"
    # no ODOM at all: no odometry (unless asked for), and nothing tells what the poses are
    p.write_text("\n".join(_flaser(181, (0.1 * k, 0, 0), float(k)) for k in range(4)) + "\n")
    log = read_carmen(p)
    assert all(r.odom is None for r in log.records) and log.odom_valid is not None and not log.odom_valid.any()
    assert log.reference_kind == "unknown"
    # raw: the laser poses are the odometry at the scan (on the ODOM stream)
    raw = [x for k in range(4) for x in (_odom((0.1 * k, 0, 0), k - 0.01), _flaser(181, (0.1 * k, 0, 0), k))]
    p.write_text("\n".join(raw) + "\n")
    assert read_carmen(p).reference_kind == "raw_odometry"
    # Radish "-corrected": the ODOM stream restarts at each laser pose
    cor = [_odom((0, 0, 0), 0.0), _flaser(181, (0, 0, 0), 0.0)]
    for k in range(1, 4):
        cor += [_odom((0.3 * (k - 1), 0, 0), 0.0), _odom((0.3 * k - 0.05, 0.02, 0), k - 0.01),
                _flaser(181, (0.3 * k, 0, 0), k)]
    p.write_text("\n".join(cor) + "\n")
    assert read_carmen(p).reference_kind == "corrected"


def test_a_raw_log_is_not_scored_against_its_own_odometry(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    truth = carmen_synth.loop(40, 0.25)[:40]
    odom = carmen_synth.drifted(truth, 0.02, rng)
    carmen_synth.write_log(tmp_path / "sim.log", truth, odom, rng)  # laser poses = truth: a reference
    # a raw log: the laser lines hold the odometry the ODOM lines hold
    raw_lines = [ln for ln in (tmp_path / "sim.log").read_text().splitlines()]
    out = []
    k = 0
    for ln in raw_lines:
        if ln.startswith("FLASER"):
            o: Pose2D = odom[k]
            tok = ln.split()
            n = int(tok[1])
            tok[2 + n:2 + n + 6] = [f"{v:.6f}" for v in (o.x, o.y, o.yaw, o.x, o.y, o.yaw)]
            ln = " ".join(tok)
            k += 1
        out.append(ln)
    (tmp_path / "raw.log").write_text("\n".join(out) + "\n")
    sim = run_log(tmp_path / "sim.log", tmp_path / "out_sim")
    res = CliRunner().invoke(app, ["slam", "run", str(tmp_path / "raw.log"), "--out", str(tmp_path / "out_raw")])
    assert res.exit_code == 0, res.output
    assert "raw wheel odometry, not a reference" in res.output and "slam: ATE" not in res.output
    raw = json.loads((tmp_path / "out_raw" / "report.json").read_text())
    assert sim["reference"]["kind"] == "independent" and "slam" in sim
    assert raw["reference"]["kind"] == "raw_odometry" and "slam" not in raw and "odometry_only" not in raw
    assert not (tmp_path / "out_raw" / "reference.tum").exists()
    assert raw["scans"] == 40
