"""LaserScan message codecs: ROS 2 CDR (sensor_msgs/msg/LaserScan), JSON (ROS or Foxglove field names)
and Foxglove protobuf (foxglove.LaserScan), all decoded to sim.types.LidarScan.

The protobuf reader is a few lines of wire-format parsing for this one message, so reading Foxglove
recordings needs no protobuf runtime.
"""

from __future__ import annotations

import json
import math
import struct
from typing import Any

import numpy as np

from sim.errors import ErrorCode, FleetError
from sim.types import LidarScan

ROS2_LASERSCAN = "sensor_msgs/msg/LaserScan"
ROS2_LASERSCAN_MSGDEF = """std_msgs/Header header
float32 angle_min
float32 angle_max
float32 angle_increment
float32 time_increment
float32 scan_time
float32 range_min
float32 range_max
float32[] ranges
float32[] intensities
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"""


def split_stamp(stamp: float) -> tuple[int, int]:
    """Seconds → (sec, nanosec) with 0 ≤ nanosec < 1e9."""
    ns = round(stamp * 1e9)
    return ns // 1_000_000_000, ns % 1_000_000_000


def _scan(robot: str, stamp: float, angle_min: float, inc: float, rmin: float, rmax: float,
          ranges: np.ndarray) -> LidarScan:
    r = np.asarray(ranges, dtype=np.float64).copy()
    r[~np.isfinite(r) | (r < rmin) | (r > rmax)] = np.inf  # REP-117: no return is +inf
    return LidarScan(robot, stamp, float(angle_min), float(inc), float(rmin), float(rmax), r)


# ---- ROS 2 CDR ------------------------------------------------------------------------------------------


def decode_cdr(data: bytes, robot: str) -> LidarScan:
    if len(data) < 4 or data[1] not in (0, 1):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, "not a CDR message (bad encapsulation header)")
    e = "<" if data[1] == 1 else ">"
    buf, pos = memoryview(data)[4:], 0

    def take(fmt: str, size: int) -> Any:
        nonlocal pos
        pos += -pos % size  # CDR aligns each primitive to its size, from the end of the header
        v = struct.unpack_from(e + fmt, buf, pos)
        pos += struct.calcsize(e + fmt)
        return v

    sec, nsec = take("iI", 4)
    (n,) = take("I", 4)
    pos += n  # frame_id incl. its NUL
    amin, _amax, inc, _tinc, _st, rmin, rmax = take("7f", 4)
    (count,) = take("I", 4)
    ranges = np.array(take(f"{count}f", 4), dtype=np.float64)
    return _scan(robot, sec + nsec * 1e-9, amin, inc, rmin, rmax, ranges)


def encode_cdr(scan: LidarScan, frame_id: str = "lidar") -> bytes:
    n = scan.ranges.size
    head = struct.pack("<4BiI", 0, 1, 0, 0, *split_stamp(scan.stamp))
    name = frame_id.encode() + b"\0"
    out = head + struct.pack("<I", len(name)) + name
    out += b"\0" * (-(len(out) - 4) % 4)
    amax = scan.angle_min + scan.angle_increment * (n - 1)
    out += struct.pack("<7f", scan.angle_min, amax, scan.angle_increment, 0.0, 0.1, scan.range_min, scan.range_max)
    return out + struct.pack(f"<I{n}f", n, *scan.ranges) + struct.pack("<I", 0)


# ---- JSON -----------------------------------------------------------------------------------------------


def decode_json(data: bytes, robot: str) -> LidarScan:
    try:
        m = json.loads(data)
        if "angle_min" in m:  # ROS field names
            st = m.get("header", {}).get("stamp", {})
            stamp = float(st.get("sec", 0)) + float(st.get("nanosec", st.get("nsec", 0))) * 1e-9
            return _scan(robot, stamp, m["angle_min"], m["angle_increment"], m.get("range_min", 0.0),
                         m.get("range_max", math.inf), np.array(m["ranges"], dtype=np.float64))
        ts = m.get("timestamp", {})  # Foxglove field names
        stamp = float(ts.get("sec", 0)) + float(ts.get("nsec", 0)) * 1e-9
        ranges = np.array([math.inf if v is None else v for v in m["ranges"]], dtype=np.float64)
        return _foxglove(robot, stamp, float(m["start_angle"]), float(m["end_angle"]), ranges)
    except (KeyError, TypeError, ValueError) as exc:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"JSON message is not a LaserScan: {exc}",
                         "expected ROS (angle_min, angle_increment, ranges) or Foxglove (start_angle, "
                         "end_angle, ranges) fields") from exc


def encode_json(scan: LidarScan) -> bytes:
    sec, nsec = split_stamp(scan.stamp)
    return json.dumps({
        "header": {"stamp": {"sec": sec, "nanosec": nsec}, "frame_id": "lidar"},
        "angle_min": scan.angle_min, "angle_max": scan.angle_min + scan.angle_increment * (scan.ranges.size - 1),
        "angle_increment": scan.angle_increment, "range_min": scan.range_min, "range_max": scan.range_max,
        "ranges": [None if not math.isfinite(v) else float(v) for v in scan.ranges],
    }).encode()


def _foxglove(robot: str, stamp: float, start: float, end: float, ranges: np.ndarray) -> LidarScan:
    inc = (end - start) / (ranges.size - 1) if ranges.size > 1 else 0.0
    return _scan(robot, stamp, start, inc, 0.0, math.inf, ranges)


# ---- Foxglove protobuf ----------------------------------------------------------------------------------


def _varint(b: bytes, i: int) -> tuple[int, int]:
    v = shift = 0
    while True:
        c = b[i]
        i += 1
        v |= (c & 0x7F) << shift
        shift += 7
        if not c & 0x80:
            return v, i


def _fields(b: bytes) -> dict[int, list[Any]]:
    """Protobuf wire format → {field number: [values]} (varints as int, fixed64 as bytes, LEN as bytes)."""
    out: dict[int, list[Any]] = {}
    i = 0
    while i < len(b):
        key, i = _varint(b, i)
        num, wt = key >> 3, key & 7
        v: int | bytes
        if wt == 0:
            v, i = _varint(b, i)
        elif wt == 1:
            v, i = b[i:i + 8], i + 8
        elif wt == 2:
            n, i = _varint(b, i)
            v, i = b[i:i + n], i + n
        elif wt == 5:
            v, i = b[i:i + 4], i + 4
        else:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"unsupported protobuf wire type {wt}")
        out.setdefault(num, []).append(v)
    return out


def decode_foxglove_protobuf(data: bytes, robot: str) -> LidarScan:
    """foxglove.LaserScan: 1 timestamp{1 sec, 2 nsec}, 4 start_angle, 5 end_angle, 6 packed ranges."""
    f = _fields(bytes(data))
    ts = _fields(f[1][0]) if 1 in f else {}
    stamp = ts.get(1, [0])[0] + ts.get(2, [0])[0] * 1e-9
    start = struct.unpack("<d", f[4][0])[0] if 4 in f else 0.0
    end = struct.unpack("<d", f[5][0])[0] if 5 in f else 0.0
    raw = b"".join(f.get(6, []))
    return _foxglove(robot, stamp, start, end, np.frombuffer(raw, dtype="<f8").astype(np.float64))
