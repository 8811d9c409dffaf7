"""A world served over Zenoh on a loopback port, in the test process, for CLI clients run as subprocesses."""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from fleet import FleetConfig, FleetService
from fleet.grading.agent_run import free_port
from fleet.paths import ROOT
from fleet.zenoh_bridge import ZenohBridge
from fleet.zenoh_config import loopback
from sim.clock import ClockMode
from sim.types import Pose2D


@dataclass
class Served:
    service: FleetService
    endpoint: str


@contextmanager
def served_world(speed: float = 1.0, world: str = "empty") -> Iterator[Served]:
    """`r1` at the origin facing +x, the world running in real time × `speed`."""
    svc = FleetService(FleetConfig(world=world, seed=1))
    port = free_port()
    try:
        svc.spawn_robot("r1", Pose2D(0.0, 0.0, 0.0))
        svc.start(ClockMode.REALTIME, speed)
        with ZenohBridge(svc, loopback(port, listen=True)):
            yield Served(svc, f"tcp/127.0.0.1:{port}")
    finally:
        svc.close()


def cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "fleetnav.cli", *args]


def env() -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": str(ROOT), "PYTHONUNBUFFERED": "1"}
