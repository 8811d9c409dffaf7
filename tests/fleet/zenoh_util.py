"""Helpers for the Zenoh tests: a world served on a free loopback port, example processes, deadline polling."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from fleet import FleetConfig, FleetService
from fleet.zenoh_bridge import ZenohBridge
from fleet.zenoh_config import ZenohConfig, loopback

ROOT = Path(__file__).resolve().parents[2]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextmanager
def served(world: str = "empty", *, seed: int = 1, robots: dict[str, tuple[float, float, float]] | None = None,
           clock: str = "realtime", speed: float = 1.0, fleet: dict[str, Any] | None = None,
           config: ZenohConfig | None = None, **zenoh_kw: Any) -> Iterator[tuple[FleetService, ZenohBridge, str]]:
    """A FleetService in service mode with a ZenohBridge listening on 127.0.0.1:<free port>, no multicast
    (or on what `config` says)."""
    from sim import Pose2D

    port = free_port()
    config = config or loopback(port, listen=True, **zenoh_kw)
    svc = FleetService(FleetConfig(world=world, seed=seed, **(fleet or {})))
    try:
        for name, (x, y, yaw) in (robots or {}).items():
            svc.spawn_robot(name, Pose2D(x, y, yaw))
        svc.start(clock, speed)
        with ZenohBridge(svc, config) as bridge:
            yield svc, bridge, config.listen[0]
    finally:
        svc.close()


def wait_until(predicate: Callable[[], object], timeout: float = 10.0, what: str = "condition") -> None:
    """Poll `predicate` until it holds or the deadline passes (for state that has no notification)."""
    deadline = time.monotonic() + timeout
    pause = threading.Event()
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout} s waiting for {what}")
        pause.wait(0.01)


def example(script: str, *args: str) -> subprocess.Popen[str]:
    """Start examples/<script> as its own Python process."""
    return subprocess.Popen([sys.executable, str(ROOT / "examples" / script), *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=ROOT)


def result_of(proc: subprocess.Popen[str], timeout: float = 60.0) -> dict[str, Any]:
    out, err = proc.communicate(timeout=timeout)
    lines = [ln for ln in out.splitlines() if ln.startswith("{")]
    assert lines, f"no result from the agent process (exit {proc.returncode}): {err[-2000:]}"
    return dict(json.loads(lines[-1]))


def events_of(svc: FleetService, kind: str) -> list[Any]:
    return [e for e in svc.events.since(0) if e.kind == kind]
