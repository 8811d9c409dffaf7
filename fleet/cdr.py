"""ROS 2 CDR (XCDR1, little-endian) for the three messages ROS tools exchange with a robot.

`geometry_msgs/Twist`, `sensor_msgs/LaserScan`, `nav_msgs/Odometry`, byte-compatible with what rmw
implementations and zenoh-bridge-ros2dds put on the wire: a 4-byte encapsulation header (0x00 0x01 = CDR_LE,
two option bytes), then fields aligned to their own size counted from the end of that header; strings are
uint32 length (including the NUL) + bytes + NUL; sequences are uint32 count + elements.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass, field

import numpy as np

from sim.errors import ErrorCode, FleetError

CDR_LE = b"\x00\x01\x00\x00"


@dataclass(frozen=True, slots=True)
class Header:
    stamp: float  # sim time, s
    frame_id: str


@dataclass(frozen=True, slots=True)
class Twist:
    linear: tuple[float, float, float] = (0.0, 0.0, 0.0)
    angular: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True, slots=True)
class LaserScan:
    header: Header
    angle_min: float
    angle_max: float
    angle_increment: float
    time_increment: float
    scan_time: float
    range_min: float
    range_max: float
    ranges: np.ndarray  # float32
    intensities: np.ndarray = field(default_factory=lambda: np.zeros(0, np.float32))


@dataclass(frozen=True, slots=True)
class Odometry:
    header: Header
    child_frame_id: str
    position: tuple[float, float, float]
    orientation: tuple[float, float, float, float]  # x y z w
    pose_covariance: tuple[float, ...]  # 36, row-major
    linear: tuple[float, float, float]
    angular: tuple[float, float, float]
    twist_covariance: tuple[float, ...]  # 36


def split_stamp(t: float) -> tuple[int, int]:
    """Sim seconds → builtin_interfaces/Time (sec, nanosec), nanosec always in [0, 1e9)."""
    sec = math.floor(t)
    ns = round((t - sec) * 1e9)
    if ns >= 1_000_000_000:
        sec, ns = sec + 1, ns - 1_000_000_000
    return int(sec), int(ns)


class _Writer:
    def __init__(self) -> None:
        self.buf = bytearray()

    def _align(self, n: int) -> None:
        self.buf += b"\x00" * (-len(self.buf) % n)

    def pack(self, fmt: str, *values: float | int) -> None:
        self._align(struct.calcsize("<" + fmt[-1]))  # each fmt here is one type (or same-size types): align to it
        self.buf += struct.pack(fmt, *values)

    def string(self, s: str) -> None:
        raw = s.encode() + b"\x00"
        self.pack("<I", len(raw))
        self.buf += raw

    def floats(self, a: np.ndarray) -> None:
        self.pack("<I", a.size)
        self._align(4)
        self.buf += np.ascontiguousarray(a, dtype="<f4").tobytes()

    def header(self, h: Header) -> None:
        self.pack("<iI", *split_stamp(h.stamp))
        self.string(h.frame_id)

    def payload(self) -> bytes:
        return CDR_LE + bytes(self.buf)


class _Reader:
    def __init__(self, data: bytes, what: str) -> None:
        if len(data) < 4 or data[:2] != CDR_LE[:2]:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{what}: not little-endian CDR (header {data[:4].hex()})",
                             "send XCDR1 little-endian (encapsulation 00 01 00 00)")
        self.data, self.pos, self.what = memoryview(data)[4:], 0, what

    def _need(self, n: int) -> None:
        if self.pos + n > len(self.data):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{self.what}: CDR payload truncated at byte {self.pos + 4}")

    def unpack(self, fmt: str) -> tuple[float | int, ...]:
        self.pos += -self.pos % struct.calcsize("<" + fmt[-1])
        size = struct.calcsize("<" + fmt)
        self._need(size)
        out = struct.unpack_from("<" + fmt, self.data, self.pos)
        self.pos += size
        return out

    def string(self) -> str:
        (n,) = self.unpack("I")
        self._need(int(n))
        raw = bytes(self.data[self.pos:self.pos + int(n)])
        self.pos += int(n)
        if not raw.endswith(b"\x00"):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{self.what}: CDR string is not NUL-terminated")
        return raw[:-1].decode(errors="replace")

    def floats(self) -> np.ndarray:
        (n,) = self.unpack("I")
        self._need(4 * int(n))
        a = np.frombuffer(self.data, dtype="<f4", count=int(n), offset=self.pos).astype(np.float32)
        self.pos += 4 * int(n)
        return a

    def header(self) -> Header:
        sec, ns = self.unpack("iI")
        return Header(float(sec) + float(ns) * 1e-9, self.string())


# ---- geometry_msgs/Twist ----------------------------------------------------------------------------------


def encode_twist(t: Twist) -> bytes:
    w = _Writer()
    w.pack("<6d", *t.linear, *t.angular)
    return w.payload()


def decode_twist(data: bytes) -> Twist:
    r = _Reader(data, "geometry_msgs/Twist")
    v = tuple(float(x) for x in r.unpack("6d"))
    return Twist(v[:3], v[3:])  # type: ignore[arg-type]


# ---- sensor_msgs/LaserScan ----------------------------------------------------------------------------------


def encode_laser_scan(s: LaserScan) -> bytes:
    w = _Writer()
    w.header(s.header)
    w.pack("<7f", s.angle_min, s.angle_max, s.angle_increment, s.time_increment, s.scan_time, s.range_min,
           s.range_max)
    w.floats(s.ranges)
    w.floats(s.intensities)
    return w.payload()


def decode_laser_scan(data: bytes) -> LaserScan:
    r = _Reader(data, "sensor_msgs/LaserScan")
    h = r.header()
    a_min, a_max, a_inc, t_inc, scan_t, r_min, r_max = (float(x) for x in r.unpack("7f"))
    ranges = r.floats()
    return LaserScan(h, a_min, a_max, a_inc, t_inc, scan_t, r_min, r_max, ranges, r.floats())


# ---- nav_msgs/Odometry ----------------------------------------------------------------------------------------


def encode_odometry(o: Odometry) -> bytes:
    w = _Writer()
    w.header(o.header)
    w.string(o.child_frame_id)
    w.pack("<7d", *o.position, *o.orientation)
    w.pack("<36d", *o.pose_covariance)
    w.pack("<6d", *o.linear, *o.angular)
    w.pack("<36d", *o.twist_covariance)
    return w.payload()


def decode_odometry(data: bytes) -> Odometry:
    r = _Reader(data, "nav_msgs/Odometry")
    h, child = r.header(), r.string()
    p = [float(x) for x in r.unpack("7d")]
    pc = tuple(float(x) for x in r.unpack("36d"))
    t = [float(x) for x in r.unpack("6d")]
    tc = tuple(float(x) for x in r.unpack("36d"))
    return Odometry(h, child, (p[0], p[1], p[2]), (p[3], p[4], p[5], p[6]), pc, (t[0], t[1], t[2]),
                    (t[3], t[4], t[5]), tc)


def yaw_quaternion(yaw: float) -> tuple[float, float, float, float]:
    return (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))
