"""CARMEN log files as a scan input: FLASER, ROBOTLASER1 and ODOM lines (other lines are skipped).

FLASER n r1..rn x y theta odom_x odom_y odom_theta timestamp host logger_timestamp
    n beams over 180° starting at −90° (the classic SICK setting; override with `flaser_fov`).
ROBOTLASER1 type start_angle fov resolution max_range accuracy remission_mode n r1..rn m i1..im
    laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv fwd_safety side_safety turn_axis
    timestamp host logger_timestamp
ODOM x y theta tv rv accel timestamp host logger_timestamp

Each scan's record carries the robot's odometry pose from its own line; ranges at or beyond the
maximum range are "no return" (+inf, REP-117).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sim.errors import ErrorCode, FleetError
from sim.transforms import se2_between
from sim.types import LidarScan, Pose2D
from slam.types import ScanRecord


@dataclass(frozen=True, slots=True)
class CarmenLog:
    records: list[ScanRecord]  # scans with the odometry pose at their time
    odometry: list[tuple[float, Pose2D]] = field(default_factory=list)  # ODOM lines: (stamp, pose)
    lidar_offset: tuple[float, float, float] | None = None  # laser in the robot frame (ROBOTLASER1)
    skipped: dict[str, int] = field(default_factory=dict)  # other message types, by name


def read_carmen(path: str | Path, *, max_range: float = 50.0, flaser_fov: float = math.pi,
                robot: str = "carmen") -> CarmenLog:
    p = Path(path)
    try:
        lines = p.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError as exc:
        raise FleetError(ErrorCode.NOT_FOUND, f"cannot read {p}: {exc.strerror}", "check the path") from exc
    records: list[ScanRecord] = []
    odom: list[tuple[float, Pose2D]] = []
    skipped: dict[str, int] = {}
    offset: tuple[float, float, float] | None = None
    for no, line in enumerate(lines, 1):
        tok = line.split()
        if not tok or tok[0].startswith("#"):
            continue
        try:
            if tok[0] == "FLASER":
                records.append(_flaser(tok, max_range, flaser_fov, robot))
            elif tok[0] == "ROBOTLASER1":
                rec, off = _robotlaser(tok, max_range, robot)
                records.append(rec)
                offset = offset or off
            elif tok[0] == "ODOM":
                v = [float(t) for t in tok[1:8]]
                odom.append((v[6], Pose2D(v[0], v[1], v[2])))
            else:
                skipped[tok[0]] = skipped.get(tok[0], 0) + 1
        except (ValueError, IndexError) as exc:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{p}:{no}: malformed {tok[0]} line ({exc})",
                             "see the CARMEN log format in slam/io_carmen.py") from exc
    if not records:
        raise FleetError(ErrorCode.NOT_FOUND, f"{p}: no FLASER or ROBOTLASER1 lines", "is this a CARMEN log?")
    return CarmenLog(records, odom, offset, skipped)


def _ranges(values: list[str], max_range: float) -> np.ndarray:
    r = np.array([float(v) for v in values], dtype=np.float64)
    r[~np.isfinite(r) | (r >= max_range) | (r <= 0.0)] = np.inf
    return r


def _flaser(tok: list[str], max_range: float, fov: float, robot: str) -> ScanRecord:
    n = int(tok[1])
    r = _ranges(tok[2:2 + n], max_range)
    if r.size != n:
        raise IndexError(f"expected {n} ranges, got {r.size}")
    rest = [float(t) for t in tok[2 + n:2 + n + 7]]
    if len(rest) < 7:
        raise IndexError("missing pose or timestamp fields")
    odom = Pose2D(rest[3], rest[4], rest[5])
    scan = LidarScan(robot, rest[6], -fov / 2, fov / n, 0.0, max_range, r)
    return ScanRecord(scan, odom)


def _robotlaser(tok: list[str], max_range: float, robot: str) -> tuple[ScanRecord, tuple[float, float, float]]:
    start, _fov, res, rmax = (float(t) for t in tok[2:6])
    n = int(tok[8])
    r = _ranges(tok[9:9 + n], min(max_range, rmax))
    i = 9 + n
    m = int(tok[i])
    i += 1 + m
    v = [float(t) for t in tok[i:i + 12]]
    if len(v) < 12 or r.size != n:
        raise IndexError("missing fields after the remission values")
    laser, base, stamp = (v[0], v[1], v[2]), (v[3], v[4], v[5]), v[11]
    scan = LidarScan(robot, stamp, start, res, 0.0, min(max_range, rmax), r)
    return ScanRecord(scan, Pose2D(*base)), se2_between(base, laser)


def format_flaser(scan: LidarScan, odom: Pose2D, laser: Pose2D | None = None, host: str = "fleetnav") -> str:
    """One FLASER line (used to write logs for tests and exports); ranges must span 180° from −90°."""
    lp = laser or odom
    vals = " ".join(f"{(v if math.isfinite(v) else scan.range_max):.3f}" for v in scan.ranges)
    return (f"FLASER {scan.ranges.size} {vals} {lp.x:.6f} {lp.y:.6f} {lp.yaw:.6f} {odom.x:.6f} {odom.y:.6f} "
            f"{odom.yaw:.6f} {scan.stamp:.6f} {host} {scan.stamp:.6f}")
