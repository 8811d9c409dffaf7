"""Agent processes for the lease/rate/heartbeat tests and benchmarks/zenoh.py: `python zenoh_agent_proc.py MODE
ENDPOINT ...`. Each prints JSON lines on stdout (times are wall `time.time()`, comparable across processes)."""

from __future__ import annotations

import json
import random
import sys
import time
from typing import Any

from fleet.agent import Agent
from sim.errors import ErrorCode, FleetError


def out(**msg: Any) -> None:
    print(json.dumps(msg), flush=True)


def quick(ep: str, robot: str, trials: int) -> None:
    """Per trial: a new session takes the lease (drive_sync), publishes one more command and exits at once —
    what the shipped examples do. Waits for a line on stdin before the next trial."""
    for i in range(trials):
        agent = Agent(f"quick{i}", connect=ep).open()
        link = agent.robot(robot, streams=())
        link.drive_sync(0.1, 0.0)
        link.drive(0.1, 0.0)  # in flight while the session closes
        closing_at = time.time()
        agent.close()
        out(trial=i, agent=f"quick{i}", closing_at=closing_at, closed_at=time.time())
        if i + 1 < trials:
            sys.stdin.readline()


def idle(ep: str, robot: str, seconds: float) -> None:
    """Take the lease, then stay connected (heartbeating) and silent."""
    with Agent("idler", connect=ep) as agent:
        agent.robot(robot, streams=()).drive_sync(0.0, 0.0)
        out(acquired_at=time.time())
        time.sleep(seconds)


def hold(ep: str, robot: str, seconds: float, heartbeat_hz: float) -> None:
    """Drive at 10 Hz (wall) until killed or `seconds` pass."""
    with Agent("holder", connect=ep, heartbeat_hz=heartbeat_hz) as agent:
        link = agent.robot(robot, streams=())
        link.drive_sync(0.3, 0.0)
        out(acquired_at=time.time())
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            link.drive(0.3, 0.0)
            time.sleep(0.1)


def fleet(ep: str, n: int, hz: float, seconds: float) -> None:
    """One agent drives robots f0..f{n-1}, each at `hz` (wall), for `seconds`."""
    with Agent("fleet_ctl", connect=ep) as agent:
        links = [agent.robot(f"f{i}", streams=()) for i in range(n)]
        sent, period = 0, 1.0 / hz
        start = time.monotonic()
        for tick in range(round(hz * seconds)):
            time.sleep(max(0.0, start + tick * period - time.monotonic()))
            for k, link in enumerate(links):
                link.drive(0.1, 0.05 * (k % 3 - 1))
                sent += 1
        time.sleep(0.5)  # rejections are reported asynchronously
        out(sent=sent, errors=[e["message"] for e in agent.errors][:20], n_errors=len(agent.errors),
            wall_s=time.monotonic() - start)


def race(ep: str, robot: str, me: str, seconds: float, hold_n: int, seed: int) -> None:
    """Race for one robot: drive_sync; after `hold_n` accepted commands release it; log every outcome."""
    rng = random.Random(seed)
    log: list[dict[str, Any]] = []
    with Agent(me, connect=ep) as agent:
        link = agent.robot(robot, streams=())
        held, end = 0, time.monotonic() + seconds
        while time.monotonic() < end:
            t0 = time.time()
            try:
                link.drive_sync(0.0, 0.1)
                log.append({"ok": True, "t0": t0, "t1": time.time()})
                held += 1
                if held >= hold_n:
                    t0 = time.time()
                    agent.release(robot)
                    log.append({"release": True, "t0": t0, "t1": time.time()})
                    held = 0
            except FleetError as exc:
                if exc.code is not ErrorCode.LEASE_HELD:
                    raise
                log.append({"ok": False, "t0": t0, "t1": time.time(), "message": exc.message})
                held = 0
            time.sleep(rng.uniform(0.04, 0.09))  # together under the per-robot rate limit (4 × control rate)
    out(agent=me, log=log)


if __name__ == "__main__":
    mode, ep, *rest = sys.argv[1:]
    if mode == "quick":
        quick(ep, rest[0], int(rest[1]))
    elif mode == "idle":
        idle(ep, rest[0], float(rest[1]))
    elif mode == "hold":
        hold(ep, rest[0], float(rest[1]), float(rest[2]))
    elif mode == "fleet":
        fleet(ep, int(rest[0]), float(rest[1]), float(rest[2]))
    elif mode == "race":
        race(ep, rest[0], rest[1], float(rest[2]), int(rest[3]), int(rest[4]))
    else:
        raise SystemExit(f"unknown mode {mode}")
