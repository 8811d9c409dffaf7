"""Health of every sensor stream of a fleet: one StreamMonitor per (robot, sensor), fed by World readings.

Streams are named "<robot>/<kind>" with the kinds of `World.subscribe` (scan, imu, odom). Configured
rates and nominal noise come from the robot's RobotSpec, so a degraded sensor (noise_scale) or a silent
one (dropout) shows against what the robot model says it should do.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any, Protocol

import numpy as np

from sim.errors import ErrorCode, FleetError, unknown_name
from sim.perception.health import StreamMonitor
from sim.perception.types import HealthAlert, StreamConfig, StreamHealth
from sim.robot_spec import RobotSpec
from sim.types import CameraImage, ContactReading, ImuReading, LidarScan, OdometryReading

KINDS = ("scan", "imu", "odom")
Reading = LidarScan | ImuReading | OdometryReading | ContactReading | CameraImage


class ReadingSource(Protocol):
    """What the monitor needs from sim.World (kept structural so perception never imports PyBullet)."""

    @property
    def time(self) -> float: ...

    def subscribe(self, callback: Callable[[Any], None], kinds: tuple[str, ...] = ...
                  ) -> Callable[[], None]: ...


def reading_kind(reading: object) -> str:
    kinds: dict[type, str] = {LidarScan: "scan", ImuReading: "imu", OdometryReading: "odom",
                              ContactReading: "contact", CameraImage: "camera"}
    kind = kinds.get(type(reading))
    if kind is None:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"not a sensor reading: {type(reading).__name__}",
                         "pass a LidarScan, ImuReading, OdometryReading, ContactReading or CameraImage")
    return kind


def reading_values(reading: object) -> np.ndarray | None:
    """The vector whose sample-to-sample noise the monitor tracks: lidar ranges, gyro rates, odom twist."""
    if isinstance(reading, LidarScan):
        return np.where(np.isfinite(reading.ranges), reading.ranges, np.nan)
    if isinstance(reading, ImuReading):
        return np.asarray(reading.angular_velocity, dtype=float)
    if isinstance(reading, OdometryReading):
        return np.array([reading.linear, reading.angular])
    return None


def stream_configs(spec: RobotSpec, **overrides: float) -> dict[str, StreamConfig]:
    """Expected rate and noise of each enabled stream of a robot; overrides (e.g. dropout_factor=2) apply
    to all of them."""
    s = spec.sensors
    out: dict[str, StreamConfig] = {}
    if s.lidar.enabled:
        out["scan"] = StreamConfig(rate_hz=s.lidar.rate_hz, nominal_noise=s.lidar.noise_std or None,
                                   **overrides)
    if s.imu.enabled:
        out["imu"] = StreamConfig(rate_hz=s.imu.rate_hz, nominal_noise=s.imu.gyro_noise_std or None,
                                  **overrides)
    if s.odometry.enabled:
        out["odom"] = StreamConfig(rate_hz=s.odometry.rate_hz, **overrides)
    return out


class SensorHealthMonitor:
    def __init__(self) -> None:
        self._streams: dict[str, StreamMonitor] = {}

    def add_stream(self, name: str, config: StreamConfig) -> None:
        if name in self._streams:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"stream '{name}' is already monitored", "")
        self._streams[name] = StreamMonitor(name, **config.model_dump())

    def add_robot(self, robot: str, spec: RobotSpec, **overrides: float) -> None:
        for kind, cfg in stream_configs(spec, **overrides).items():
            self.add_stream(f"{robot}/{kind}", cfg)

    def streams(self) -> list[str]:
        return sorted(self._streams)

    def observe(self, reading: Reading, received: float | None = None) -> bool:
        """Feed one reading; False (and ignored) when its stream is not monitored."""
        mon = self._streams.get(f"{reading.robot}/{reading_kind(reading)}")
        if mon is None:
            return False
        mon.observe(float(reading.stamp), received, reading_values(reading))
        return True

    def attach(self, world: ReadingSource, kinds: Iterable[str] = KINDS) -> Callable[[], None]:
        """Subscribe to the world's readings (received at `world.time`); returns the unsubscribe call."""
        def on_reading(reading: Reading) -> None:
            self.observe(reading, world.time)

        return world.subscribe(on_reading, kinds=tuple(kinds))

    def report(self, now: float, stream: str | None = None) -> dict[str, StreamHealth]:
        if stream is not None:
            if stream not in self._streams:
                raise unknown_name("stream", stream, list(self._streams), ErrorCode.NOT_FOUND)
            return {stream: self._streams[stream].report(now)}
        return {name: mon.report(now) for name, mon in sorted(self._streams.items())}

    def alerts(self, now: float) -> list[HealthAlert]:
        return [a for h in self.report(now).values() for a in h.alerts]
