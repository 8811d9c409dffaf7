"""CARMEN reading for log SLAM: .gz, 181/361-beam layouts, ODOM increments interpolated to the scan stamp,
"-corrected" restarts, the odometry sources, RLASER/RAWLASER lines, errors naming file and line."""

from __future__ import annotations

import gzip
import math
from pathlib import Path

import pytest

from sim.errors import FleetError
from slam.io_carmen import read_carmen


def _flaser(n: int, pose: tuple[float, float, float], t: float, kind: str = "FLASER") -> str:
    r = " ".join(f"{1.0 + 0.001 * k:.3f}" for k in range(n))
    x, y, th = pose
    return f"{kind} {n} {r} {x} {y} {th} {x} {y} {th} {t} host {t}"


@pytest.mark.parametrize(("n", "step_deg"), [(181, 1.0), (361, 0.5), (180, 1.0), (360, 0.5), (100, 180 / 99)])
def test_beam_layout_and_gz(tmp_path: Path, n: int, step_deg: float) -> None:
    text = "\n".join(["ODOM 0 0 0 0 0 0 0.0 h 0", _flaser(n, (0, 0, 0), 0.0), "ODOM 1 0 0 0 0 0 1.0 h 1",
                      _flaser(n, (1, 0, 0), 1.0)]) + "\n"
    with gzip.open(tmp_path / "a.log.gz", "wt") as f:
        f.write(text)
    log = read_carmen(tmp_path / "a.log.gz")
    scan = log.records[0].scan
    assert scan.ranges.size == n and scan.ranges[5] == pytest.approx(1.005, abs=1e-12)
    assert scan.angle_min == pytest.approx(-math.pi / 2)
    # 181/361: first to last beam over 180°; 180/360 (a SICK scan without its last beam): 1°/0.5° from −90°
    assert scan.angle_increment == pytest.approx(math.radians(step_deg), abs=1e-12)
    assert log.reference is not None and log.reference[1].tolist() == [1.0, 0.0, 0.0]


def test_odom_increments_interpolated_to_the_scan_stamp(tmp_path: Path) -> None:
    # ODOM at t=1 (x=1, yaw=0.2) and t=3 (x=3, yaw=0.6); the scan at t=2 sits halfway: the SE(2) interpolation
    # of the increment (x 2 in the first frame, yaw 0.4) scaled by 1/2, composed onto the first pose.
    lines = ["ODOM 0 0 0 0 0 0 0.0 h 0", _flaser(181, (9, 9, 0), 0.0), "ODOM 1 0 0.2 0 0 0 1.0 h 1",
             _flaser(181, (9, 9, 0), 2.0), "ODOM 3 0 0.6 0 0 0 3.0 h 3", _flaser(181, (9, 9, 0), 3.0)]
    (tmp_path / "b.log").write_text("\n".join(lines) + "\n")
    log = read_carmen(tmp_path / "b.log")
    o = [r.odom for r in log.records]
    assert o[0] is not None and o[0].as_tuple() == (0.0, 0.0, 0.0)
    c, s = math.cos(0.2), math.sin(0.2)
    inc = (c * 2 + s * 0, -s * 2 + c * 0, 0.4)  # second ODOM in the first's frame
    half = (inc[0] / 2, inc[1] / 2, 0.2)
    expected = (1 + c * half[0] - s * half[1], s * half[0] + c * half[1], 0.4)
    assert o[1] is not None and o[1].as_tuple() == pytest.approx(expected, abs=1e-12)
    assert o[2] is not None and o[2].as_tuple() == pytest.approx((3.0, 0.0, 0.6), abs=1e-12)
    assert log.odom_valid is not None and log.odom_valid.tolist() == [False, True, True]
    # the laser lines' poses are the reference, never the odometry (unless asked for)
    laser = read_carmen(tmp_path / "b.log", odometry="laser_pose").records[1].odom
    assert laser is not None and laser.as_tuple() == (9.0, 9.0, 0.0)
    assert read_carmen(tmp_path / "b.log", odometry="none").records[1].odom is None


def test_corrected_restarts_are_not_motion(tmp_path: Path) -> None:
    # Radish "-corrected": after each laser line the ODOM restarts at its corrected pose (stamp 0), then adds
    # raw increments. Raw motion: +0.5 in x per scan; the corrected poses jump around (0.7, then 2.0).
    lines = ["ODOM 0 0 0 0 0 0 0.0 h 0", _flaser(181, (0, 0, 0), 0.0),
             "ODOM 0 0 0 0 0 0 0 h 0", "ODOM 0.5 0 0 0 0 0 1.0 h 1", _flaser(181, (0.7, 0, 0), 1.0),
             "ODOM 0.7 0 0 0 0 0 0 h 0", "ODOM 1.2 0 0 0 0 0 2.0 h 2", _flaser(181, (2.0, 0, 0), 2.0),
             "ODOM 2.0 0 0 0 0 0 0 h 0", "ODOM 2.5 0 0 0 0 0 3.0 h 3", _flaser(181, (3.0, 0, 0), 3.0)]
    (tmp_path / "c.log").write_text("\n".join(lines) + "\n")
    log = read_carmen(tmp_path / "c.log")
    xs = [r.odom.x for r in log.records if r.odom is not None]
    assert xs == pytest.approx([0.0, 0.5, 1.0, 1.5], abs=1e-12)
    assert log.reference is not None and log.reference[:, 0].tolist() == [0.0, 0.7, 2.0, 3.0]


def test_rear_and_raw_lasers(tmp_path: Path) -> None:
    raw = "RAWLASER1 0 -1.5 3.0 0.5 8.0 0.01 0 7 " + " ".join(["2.0"] * 7) + " 0 4.5 host 4.5"
    lines = [raw, _flaser(181, (1, 2, 0.5), 5.0, kind="RLASER")]
    (tmp_path / "d.log").write_text("\n".join(lines) + "\n")
    front = read_carmen(tmp_path / "d.log", odometry="none")
    s = front.records[0].scan
    assert s.ranges.tolist() == [2.0] * 7 and s.angle_min == -1.5 and s.angle_increment == 0.5 and s.stamp == 4.5
    assert front.reference is None and front.skipped == {"RLASER": 1}
    rear = read_carmen(tmp_path / "d.log", laser="rear", odometry="laser_pose")
    assert rear.records[0].scan.angle_min == pytest.approx(math.pi / 2)  # facing backwards
    assert rear.records[0].odom is not None and rear.records[0].odom.as_tuple() == (1.0, 2.0, 0.5)
    with pytest.raises(FleetError, match="carry no pose"):
        read_carmen(tmp_path / "d.log", odometry="laser_pose")


def test_errors_name_file_and_line(tmp_path: Path) -> None:
    (tmp_path / "e.log").write_text("ODOM 0 0 0 0 0 0 0 h 0\nODOM 1 2\n")
    with pytest.raises(FleetError, match=r"e.log:2: malformed ODOM"):
        read_carmen(tmp_path / "e.log")
    (tmp_path / "f.log.gz").write_bytes(b"not gzip")
    with pytest.raises(FleetError, match="gzip"):
        read_carmen(tmp_path / "f.log.gz")
    with pytest.raises(FleetError, match="unknown odometry source"):
        read_carmen(tmp_path / "e.log", odometry="wheels")  # type: ignore[arg-type]
