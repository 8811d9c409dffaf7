"""World → agents streams: per-robot sensors and state, the fleet-level state, optionally ROS 2 CDR topics.

Both entry points run on the sim thread (sensor readings inside `world.step`, snapshots after each control
tick), so they never block: high-rate streams use congestion control DROP, and a stream nobody subscribes to
costs one matching check and no encoding.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import zenoh

from fleet import cdr
from fleet.types import FleetSnapshot
from fleet.zenoh_api import (
    Keys,
    RosKeys,
    encode_fleet_state,
    encode_imu,
    encode_odom,
    encode_pose,
    encode_robot_state,
    encode_scan,
)
from fleet.zenoh_config import StreamsConfig
from sim.types import ImuReading, LidarScan, OdometryReading

JSON = zenoh.Encoding.APPLICATION_JSON
CDR = zenoh.Encoding.APPLICATION_CDR
ZERO_COV = (0.0,) * 36


class Streams:
    def __init__(self, session: zenoh.Session, keys: Keys, streams: StreamsConfig, ros: RosKeys | None, *,
                 odom_hz: float | None = None, state_hz: float | None = None) -> None:
        self.session, self.keys, self.cfg, self.ros = session, keys, streams, ros
        self.odom_hz, self.state_hz = odom_hz, state_hz
        self._slots: dict[tuple[str, str], int] = {}  # (robot or "", stream) → last rate slot published
        self._pubs: dict[tuple[str, str], zenoh.Publisher] = {}
        self._fleet = self._declare(keys.fleet("state"), JSON)
        self.published = 0  # samples put (for the benchmark's publish-rate figure)

    def _declare(self, key: str, encoding: zenoh.Encoding) -> zenoh.Publisher:
        return self.session.declare_publisher(key, encoding=encoding, congestion_control=zenoh.CongestionControl.DROP,
                                              priority=zenoh.Priority.DATA)

    def add_robot(self, robot: str) -> None:
        """Declare a robot's publishers up front, so the first reading already reaches early subscribers."""
        if (robot, "pose") in self._pubs:
            return
        for topic in ("odom", "scan", "imu", "pose", "state"):
            self._pubs[(robot, topic)] = self._declare(self.keys.robot(robot, topic), JSON)
        if self.ros is not None:
            for topic in ("odom", "scan"):
                self._pubs[(robot, "ros_" + topic)] = self._declare(self.ros.topic(robot, topic), CDR)

    def remove_robot(self, robot: str) -> None:
        for key in [k for k in self._pubs if k[0] == robot]:
            self._pubs.pop(key).undeclare()
        for key in [k for k in self._slots if k[0] == robot]:
            del self._slots[key]

    def _due(self, robot: str, stream: str, stamp: float, hz: float | None) -> bool:
        """Decimate to `hz` by sim time: at most one message per 1/hz slot (None: every message)."""
        if hz is None:
            return True
        slot = int(stamp * hz + 1e-6)
        if self._slots.get((robot, stream)) == slot:  # != rather than >: a reset world starts again at 0
            return False
        self._slots[(robot, stream)] = slot
        return True

    def close(self) -> None:
        for p in self._pubs.values():
            p.undeclare()
        self._pubs.clear()
        self._fleet.undeclare()

    def _live(self, robot: str, topic: str) -> zenoh.Publisher | None:
        pub = self._pubs.get((robot, topic))
        if pub is None and (robot, "pose") not in self._pubs:
            self.add_robot(robot)  # spawned before the bridge started: declare now
            pub = self._pubs.get((robot, topic))
        return pub if pub is not None and matching(pub) else None

    # ---- sensor readings (sim thread, inside world.step) ------------------------------------------------------

    def on_reading(self, r: object) -> None:
        if isinstance(r, OdometryReading):
            if self._due(r.robot, "odom", r.stamp, self.odom_hz):
                self._put(r.robot, "odom", self.cfg.odom, r, encode_odom)
        elif isinstance(r, LidarScan):
            self._put(r.robot, "scan", self.cfg.scan, r, encode_scan)
        elif isinstance(r, ImuReading):
            self._put(r.robot, "imu", self.cfg.imu, r, encode_imu)

    def _put(self, robot: str, topic: str, enabled: bool, r: Any, encode: Callable[[Any], bytes]) -> None:
        if enabled and (pub := self._live(robot, topic)) is not None:
            pub.put(encode(r))
            self.published += 1
        if self.ros is not None and topic != "imu" and (rp := self._live(robot, "ros_" + topic)) is not None:
            rp.put(ros_scan(r) if isinstance(r, LidarScan) else ros_odom(r))
            self.published += 1

    # ---- after each control tick (sim thread) ------------------------------------------------------------------

    def on_snapshot(self, snap: FleetSnapshot, tick: int) -> None:
        if not self._due("", "state", snap.time, self.state_hz):
            return
        if matching(self._fleet):
            self._fleet.put(encode_fleet_state(snap, tick))
            self.published += 1
        for i, name in enumerate(snap.names):
            if self.cfg.pose and (pub := self._live(name, "pose")) is not None:
                x, y, yaw = snap.pose[i]
                pub.put(encode_pose(snap.time, float(x), float(y), float(yaw)))
                self.published += 1
            if self.cfg.state and (pub := self._live(name, "state")) is not None:
                pub.put(encode_robot_state(snap, i))
                self.published += 1


def matching(pub: zenoh.Publisher) -> bool:
    """Whether anyone subscribes (the stub says bool; zenoh 1.10 returns a MatchingStatus)."""
    status: Any = pub.matching_status
    return bool(getattr(status, "matching", status))


def ros_scan(s: LidarScan) -> bytes:
    n = s.ranges.size
    return cdr.encode_laser_scan(cdr.LaserScan(
        cdr.Header(s.stamp, f"{s.robot}/lidar"), s.angle_min, s.angle_min + s.angle_increment * (n - 1),
        s.angle_increment, 0.0, 0.0, s.range_min, s.range_max, s.ranges.astype("<f4")))


def ros_odom(o: OdometryReading) -> bytes:
    p = o.pose
    return cdr.encode_odometry(cdr.Odometry(
        cdr.Header(o.stamp, f"{o.robot}/odom"), f"{o.robot}/base_link", (p.x, p.y, 0.0), cdr.yaw_quaternion(p.yaw),
        ZERO_COV, (o.linear, 0.0, 0.0), (0.0, 0.0, o.angular), ZERO_COV))
