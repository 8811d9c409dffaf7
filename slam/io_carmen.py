"""CARMEN log files (.log or .log.gz) as a scan input.

Laser lines (front: FLASER, ROBOTLASER1, RAWLASER1; rear: RLASER, RAWLASER2):
  FLASER/RLASER n r1..rn x y theta odom_x odom_y odom_theta timestamp host logger_timestamp
      n beams over 180° (the classic SICK layout: beam k at −90° + k·180°/(n−1); 180/360/720 beams, a
      SICK layout without its last beam, keep 1°/0.5°/0.25° from −90°); RLASER faces backwards.
  ROBOTLASER1 type start_angle fov resolution max_range accuracy remission_mode n r1..rn m i1..im
      laser_x laser_y laser_theta robot_x robot_y robot_theta tv rv fwd_safety side_safety turn_axis
      timestamp host logger_timestamp
  RAWLASERk type start_angle fov resolution max_range accuracy remission_mode n r1..rn m i1..im
      timestamp host logger_timestamp   (no pose)
ODOM x y theta tv rv accel timestamp host logger_timestamp

Odometry (`odometry=`):
- "odom_increments" (default, the honest one): the chain of increments between consecutive ODOM lines,
  interpolated to each scan's stamp. Radish "-corrected" logs restart the ODOM pose at each laser line's
  corrected pose (the first ODOM after a laser line equals its pose): that restart is not motion, so the
  chain skips it. A step with no ODOM sample between two scans has no odometry (`odom_valid` False). When
  the stamps carry no time (all laser stamps equal, or either stream going backwards) the chain is read in
  file order: each scan takes the latest chain sample written before its line.
- "laser_pose": the laser lines' own pose fields (in "-corrected" logs these are the corrected poses).
- "none": no odometry.
The laser lines' robot poses are always exposed as `reference` (a reference, never an input); what they are
is told by `reference_kind`: "corrected" (the ODOM stream restarts at them: a Radish "-corrected" log),
"raw_odometry" (they lie on the ODOM stream: a raw log, where they are the wheel odometry and must not be
scored against), "independent" (neither: e.g. a simulator's true poses), "unknown" (no ODOM lines to tell)
or "none" (RAWLASER lines carry no pose).
Other messages (PARAM, SYNC, NEFF, TRUEPOS, SONAR, NMEA, GPS, …) are counted in `skipped`; `#` lines are
comments; a malformed last line (a log cut off while written) is dropped and counted as "truncated"; any
other malformed line is an error naming the file and line.
Ranges at or beyond the maximum range, and the log's recurring maximum value (the laser's "no return"
code), are "no return" (+inf, REP-117).
"""

from __future__ import annotations

import gzip
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np

from sim.errors import ErrorCode, FleetError
from sim.transforms import se2_between, se2_compose
from sim.types import LidarScan, Pose2D
from slam import se2
from slam.types import ScanRecord

OdometrySource = Literal["odom_increments", "laser_pose", "none"]
LaserSide = Literal["front", "rear"]
FRONT = ("FLASER", "ROBOTLASER1", "RAWLASER1")
REAR = ("RLASER", "RAWLASER2")
_RESTART_TOL = 1e-4  # m / rad: an ODOM equal to the laser line's pose is a "-corrected" restart


@dataclass(frozen=True, slots=True)
class CarmenLog:
    records: list[ScanRecord]  # scans with the chosen odometry at their stamp (None: no odometry)
    odometry: list[tuple[float, Pose2D]] = field(default_factory=list)  # ODOM lines as written: (stamp, pose)
    lidar_offset: tuple[float, float, float] | None = None  # laser in the robot frame (ROBOTLASER1)
    skipped: dict[str, int] = field(default_factory=dict)  # other message types, by name
    reference: np.ndarray | None = None  # (n, 3) robot pose fields of the laser lines (None: RAWLASER)
    odom_valid: np.ndarray | None = None  # (n,) bool: odometry observed motion since the previous scan
    source: str = "odom_increments"
    laser_types: dict[str, int] = field(default_factory=dict)
    reference_kind: str = "unknown"  # what `reference` holds (see the module doc)
    odom_rates: np.ndarray | None = None  # (n, 4) odometry (vx, vy, ω) at each scan's stamp, robot frame, and the
    # ODOM interval (s) it was measured over (NaN: unknown)

    @property
    def stamps(self) -> np.ndarray:
        return np.array([r.scan.stamp for r in self.records])


@dataclass
class _Line:
    kind: str
    no: int
    scan: LidarScan | None = None
    pose: tuple[float, float, float] | None = None  # laser line: robot pose field; ODOM: its pose
    laser: tuple[float, float, float] | None = None
    stamp: float = 0.0


def _open_lines(p: Path) -> list[str]:
    try:
        if p.suffix == ".gz":
            with gzip.open(p, "rt", encoding="utf-8", errors="replace") as f:
                return f.read().splitlines()
        return p.read_text(encoding="utf-8", errors="replace").splitlines()
    except (EOFError, gzip.BadGzipFile) as exc:  # BadGzipFile is an OSError: catch it first
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{p}: not a readable gzip file ({exc})",
                         "give a .log or a complete .log.gz") from exc
    except OSError as exc:
        raise FleetError(ErrorCode.NOT_FOUND, f"cannot read {p}: {exc.strerror}", "check the path") from exc


def read_carmen(path: str | Path, *, max_range: float = 50.0, flaser_fov: float = math.pi,
                robot: str = "carmen", odometry: OdometrySource = "odom_increments",
                laser: LaserSide = "front", flaser_angle_min: float | None = None) -> CarmenLog:
    """Scans of one laser (`laser`: front or rear) with odometry from `odometry` (see the module doc).
    FLASER/RLASER beams span `flaser_fov` from the first to the last beam, starting at `flaser_angle_min`
    (default −fov/2, centred)."""
    if odometry not in ("odom_increments", "laser_pose", "none"):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"unknown odometry source {odometry!r}",
                         "use one of: odom_increments, laser_pose, none")
    p = Path(path)
    kinds = FRONT if laser == "front" else REAR
    parsed: list[_Line] = []
    skipped: dict[str, int] = {}
    types: dict[str, int] = {}
    offset: tuple[float, float, float] | None = None
    lines = _open_lines(p)
    last = max((k for k, ln in enumerate(lines, 1) if ln.strip()), default=0)
    for no, line in enumerate(lines, 1):
        tok = line.split()
        if not tok or tok[0].startswith("#"):
            continue
        try:
            if tok[0] == "ODOM":
                v = [float(t) for t in tok[1:8]]
                if len(v) < 7:
                    raise IndexError("ODOM needs x y theta tv rv accel timestamp")
                parsed.append(_Line("ODOM", no, pose=(v[0], v[1], v[2]), stamp=v[6]))
            elif tok[0] in kinds:
                item = _laser(tok, max_range, flaser_fov, robot, tok[0] in REAR, flaser_angle_min)
                item.no = no
                parsed.append(item)
                types[tok[0]] = types.get(tok[0], 0) + 1
                if item.laser is not None and item.pose is not None and tok[0] == "ROBOTLASER1":
                    offset = offset or se2_between(item.pose, item.laser)
            else:
                skipped[tok[0]] = skipped.get(tok[0], 0) + 1
        except (ValueError, IndexError) as exc:
            if no == last and types:  # a log with scans, cut off while written: drop its last line
                skipped["truncated"] = skipped.get("truncated", 0) + 1
                continue
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{p}:{no}: malformed {tok[0]} line ({exc})",
                             "see the CARMEN log format in slam/io_carmen.py") from exc
    scans = [x for x in parsed if x.kind != "ODOM"]
    if not scans:
        raise FleetError(ErrorCode.NOT_FOUND, f"{p}: no {' / '.join(kinds)} lines",
                         "is this a CARMEN log? (laser='rear' reads RLASER / RAWLASER2)")
    odom_lines = [(x.stamp, Pose2D(*x.pose)) for x in parsed if x.kind == "ODOM" and x.pose is not None]
    has_ref = all(s.pose is not None for s in scans)
    reference = np.array([s.pose for s in scans], dtype=np.float64) if has_ref else None
    kind = _reference_kind(parsed, reference)
    if odometry == "odom_increments":
        poses, valid, rates = _odom_chain(parsed)
    elif odometry == "laser_pose":
        if reference is None:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{p}: RAWLASER lines carry no pose",
                             "use odometry: odom_increments or none")
        poses = [(float(r[0]), float(r[1]), float(r[2])) for r in reference]
        valid = np.ones(len(scans), dtype=bool)
    else:
        poses, valid = [None] * len(scans), np.zeros(len(scans), dtype=bool)
    _mark_no_return([s.scan for s in scans if s.scan is not None])
    records = [ScanRecord(s.scan, None if q is None else Pose2D(*q))  # type: ignore[arg-type]
               for s, q in zip(scans, poses, strict=True)]
    return CarmenLog(records, odom_lines, offset, skipped, reference, valid, odometry, types, kind,
                     rates if odometry == "odom_increments" else None)


def _reference_kind(parsed: list[_Line], reference: np.ndarray | None) -> str:
    """What the laser lines' poses are (see the module doc): a "-corrected" log restarts its ODOM stream at
    (nearly) every laser line's pose with a jump from the previous ODOM; in a raw log they are the odometry at
    the scan's time, so they lie on the ODOM stream (within what the robot moves between two ODOM samples)."""
    if reference is None:
        return "none"
    odom = [x for x in parsed if x.kind == "ODOM" and x.pose is not None]
    if len(odom) < 2:
        return "unknown"
    jumps, prev, laser, after = 0, None, None, False
    on_stream = 0
    for item in parsed:
        if item.kind != "ODOM":
            laser, after = item.pose, True
            if laser is not None and prev is not None and _close(prev, laser, 0.05):
                on_stream += 1
            continue
        raw = item.pose
        assert raw is not None
        if after and laser is not None and prev is not None and _close(raw, laser, _RESTART_TOL) \
                and not _close(raw, prev, _RESTART_TOL):
            jumps += 1
        prev, after = raw, False
    n = len(reference)
    if jumps >= 0.1 * n:
        return "corrected"
    return "raw_odometry" if on_stream >= 0.9 * n else "independent"


def _close(a: tuple[float, float, float], b: tuple[float, float, float], tol: float) -> bool:
    return max(abs(a[0] - b[0]), abs(a[1] - b[1]), abs(math.remainder(a[2] - b[2], math.tau))) < tol


def _odom_chain(parsed: list[_Line]) -> tuple[list[tuple[float, float, float] | None], np.ndarray, np.ndarray]:
    """Raw odometry at each scan: chained ODOM increments (restarts skipped), interpolated in time; its valid
    flags; and its rate (vx, vy, ω; robot frame) over the ODOM interval holding the scan's stamp, with that
    interval's length (NaN without informative stamps, or where fewer than 3 ODOM samples came since the
    previous scan: then the rate would be no finer than the step between the scans)."""
    times: list[float] = []
    chain: list[tuple[float, float, float]] = []
    before: list[int] = []  # per scan: chain samples written before its line
    acc: tuple[float, float, float] | None = None
    prev_raw: tuple[float, float, float] | None = None
    last_laser: tuple[float, float, float] | None = None
    after_laser = False
    for item in parsed:
        if item.kind != "ODOM":
            before.append(len(chain))
            last_laser, after_laser = item.pose, True
            continue
        raw = item.pose
        assert raw is not None
        restart = (after_laser and last_laser is not None and prev_raw is not None
                   and max(abs(raw[0] - last_laser[0]), abs(raw[1] - last_laser[1]),
                           abs(math.remainder(raw[2] - last_laser[2], math.tau))) < _RESTART_TOL)
        after_laser = False
        if acc is None:
            acc = raw
        elif not restart and prev_raw is not None:
            acc = se2_compose(acc, se2_between(prev_raw, raw))
        prev_raw = raw
        if restart:
            continue  # a "-corrected" restart: the base moves, the robot did not
        times.append(item.stamp)
        chain.append(acc)
    n = len(before)
    rates = np.full((n, 4), np.nan)
    if not chain:
        return [None] * n, np.zeros(n, dtype=bool), rates
    t = np.array(times)
    c = np.array(chain)
    ts_all = np.array([x.scan.stamp if x.scan is not None else 0.0 for x in parsed if x.kind != "ODOM"])
    # Time interpolation needs informative stamps: both streams non-decreasing and spread out. Some logs
    # (e.g. Radish orebro) write every laser stamp as 0 and leave the ODOM stamps as garbage: file order then.
    timed = bool(np.all(np.diff(t) >= 0) and np.all(np.diff(ts_all) >= 0) and t[-1] > t[0]
                 and ts_all[-1] > ts_all[0])
    out: list[tuple[float, float, float] | None] = []
    for k, ts in enumerate(ts_all.tolist()):
        if timed and t[0] <= ts <= t[-1]:
            j = int(np.searchsorted(t, ts, side="right"))
            j = min(max(j, 1), len(t) - 1)
            out.append(_interp(t[j - 1], c[j - 1], t[j], c[j], ts))
            if t[j] > t[j - 1] and k > 0 and before[k] - before[k - 1] >= 3:  # ODOM lines finer than the scans
                rates[k, :3] = se2.between_many(c[j - 1][None], c[j][None])[0] / (t[j] - t[j - 1])
                rates[k, 3] = t[j] - t[j - 1]
        else:  # bad or out-of-range stamps: the latest sample before the line, in file order
            q = c[max(before[k] - 1, 0)]
            out.append((float(q[0]), float(q[1]), float(q[2])))
    valid = np.zeros(n, dtype=bool)
    valid[1:] = np.diff(np.array(before)) > 0  # a fresh ODOM sample since the previous scan
    return out, valid, rates


_SICK_RES = (math.radians(1.0), math.radians(0.5), math.radians(0.25))


def _flaser_layout(n: int, fov: float) -> tuple[float, float]:
    """(increment, first beam angle) of an n-beam FLASER/RLASER line spanning `fov`: n beams from −fov/2 to
    +fov/2, fov/(n−1) apart. A SICK at 1°/0.5°/0.25° over 180° gives 181/361/721 beams; logs that dropped
    the last beam (180/360/720) keep the scanner's resolution and start at −90°, so an increment within 1 %
    of fov/n at a standard resolution wins over fov/(n−1)."""
    full = fov / max(n - 1, 1)
    for res in _SICK_RES:
        if abs(fov - math.pi) < 1e-9 and abs(fov / n - res) < 0.01 * res and abs(full - res) > 0.001 * res:
            return res, -fov / 2
    return full, -fov / 2


def _mark_no_return(scans: list[LidarScan]) -> None:
    """The largest value in the log, if it recurs (≥ 0.1 % of beams and ≥ 10, ≤ half of them), is the
    laser's "no return" code (SICK 81.91, 32.767 or 51.15 in Radish logs, or the maximum a simulator writes):
    make it +inf."""
    if not scans:
        return
    top = max((float(s.ranges[np.isfinite(s.ranges)].max(initial=0.0)) for s in scans), default=0.0)
    if top <= 0.0:
        return
    total = sum(s.ranges.size for s in scans)
    hits = sum(int((s.ranges >= top - 1e-4).sum()) for s in scans)
    if max(10, 0.001 * total) <= hits <= 0.5 * total:
        for s in scans:
            s.ranges[s.ranges >= top - 1e-4] = np.inf


def _interp(t0: float, a: np.ndarray, t1: float, b: np.ndarray, t: float) -> tuple[float, float, float]:
    f = 0.0 if t1 <= t0 else (t - t0) / (t1 - t0)
    d = se2.between_many(a[None], b[None])[0] * f
    q = se2.compose_many(a[None], d[None])[0]
    return (float(q[0]), float(q[1]), float(q[2]))


def _ranges(values: list[str], max_range: float) -> np.ndarray:
    r = np.array([float(v) for v in values], dtype=np.float64)
    r[~np.isfinite(r) | (r >= max_range) | (r <= 0.0)] = np.inf
    return r


def _laser(tok: list[str], max_range: float, fov: float, robot: str, rear: bool,
           angle_min: float | None) -> _Line:
    kind = tok[0]
    if kind in ("FLASER", "RLASER"):
        n = int(tok[1])
        r = _ranges(tok[2:2 + n], max_range)
        if r.size != n:
            raise IndexError(f"expected {n} ranges, got {r.size}")
        rest = [float(t) for t in tok[2 + n:2 + n + 7]]
        if len(rest) < 7:
            raise IndexError("missing pose or timestamp fields")
        inc, first = _flaser_layout(n, fov)
        start = (first if angle_min is None else angle_min) + (math.pi if rear else 0.0)
        scan = LidarScan(robot, rest[6], start, inc, 0.0, max_range, r)
        return _Line(kind, 0, scan, (rest[3], rest[4], rest[5]), (rest[0], rest[1], rest[2]), rest[6])
    start, _fov, res, rmax = (float(t) for t in tok[2:6])
    n = int(tok[8])
    rng = min(max_range, rmax) if rmax > 0 else max_range
    r = _ranges(tok[9:9 + n], rng)
    i = 9 + n
    m = int(tok[i])
    i += 1 + m
    if kind == "ROBOTLASER1":
        v = [float(t) for t in tok[i:i + 12]]
        if len(v) < 12 or r.size != n:
            raise IndexError("missing fields after the remission values")
        scan = LidarScan(robot, v[11], start, res, 0.0, rng, r)
        return _Line(kind, 0, scan, (v[3], v[4], v[5]), (v[0], v[1], v[2]), v[11])
    if r.size != n or len(tok) <= i:
        raise IndexError("missing timestamp after the remission values")
    stamp = float(tok[i])
    return _Line(kind, 0, LidarScan(robot, stamp, start, res, 0.0, rng, r), None, None, stamp)


def format_flaser(scan: LidarScan, odom: Pose2D, laser: Pose2D | None = None, host: str = "fleetnav") -> str:
    """One FLASER line (used to write logs for tests and exports); ranges must span 180° from −90°."""
    lp = laser or odom
    vals = " ".join(f"{(v if math.isfinite(v) else scan.range_max):.3f}" for v in scan.ranges)
    return (f"FLASER {scan.ranges.size} {vals} {lp.x:.6f} {lp.y:.6f} {lp.yaw:.6f} {odom.x:.6f} {odom.y:.6f} "
            f"{odom.yaw:.6f} {scan.stamp:.6f} {host} {scan.stamp:.6f}")
