"""The safety envelope: the one chokepoint every velocity command goes through, from every front door.

Limits (clamp, or reject in strict mode, saying which), a deadman on manual commands (sim time), a latched
e-stop per robot or for the fleet with explicit re-arm, a geofence, one controlling client per robot (a
lease, wall-clock TTL) and a per-client command rate limit (wall clock).
"""

from __future__ import annotations

import math
import time
from collections import deque
from dataclasses import dataclass

from pydantic import Field

from sim.config import StrictModel
from sim.errors import ErrorCode, FleetError

AUTONOMY = "fleet"  # the client id tasks and behaviours act under


class SafetyConfig(StrictModel):
    strict: bool = Field(False, description="reject commands past the limits instead of clamping them")
    deadman_s: float = Field(0.5, gt=0, description="a manual velocity command expires after this (sim s)")
    lease_ttl_s: float = Field(30.0, gt=0, description="a lease lapses this long after its last use (wall s)")
    max_command_rate_hz: float = Field(200.0, gt=0, description="per client, wall clock")
    geofence: tuple[float, float, float, float] | None = Field(
        None, description="(xmin, ymin, xmax, ymax); null: the world's bounds")
    geofence_margin: float = Field(0.5, ge=0, description="metres added around the world's bounds")


@dataclass
class Lease:
    client: str
    expires: float  # wall clock (time.monotonic)


@dataclass(frozen=True)
class ManualCommand:
    v: float
    w: float
    expires: float  # sim time
    client: str


class SafetyEnvelope:
    def __init__(self, config: SafetyConfig, bounds: tuple[float, float, float, float]) -> None:
        self.config = config
        b = config.geofence or bounds
        m = 0.0 if config.geofence else config.geofence_margin
        self.fence = (b[0] - m, b[1] - m, b[2] + m, b[3] + m)
        self.estopped: dict[str, str] = {}  # robot → reason
        self.fleet_estop: str | None = None
        self.leases: dict[str, Lease] = {}
        self.manual: dict[str, ManualCommand] = {}
        self._rates: dict[str, deque[float]] = {}

    # ---- leases ---------------------------------------------------------------------------------------

    def holder(self, robot: str) -> str | None:
        lease = self.leases.get(robot)
        if lease is None or lease.expires < time.monotonic():
            self.leases.pop(robot, None)
            return None
        return lease.client

    def acquire(self, client: str, robot: str, ttl: float | None = None) -> Lease:
        """Take or renew the lease; fails with LEASE_HELD naming the holder if another client has it."""
        holder = self.holder(robot)
        if holder is not None and holder != client:
            raise FleetError(ErrorCode.LEASE_HELD, f"robot '{robot}' is controlled by client '{holder}'",
                             "wait for its lease to lapse or ask that client to release it")
        lease = Lease(client, time.monotonic() + (ttl or self.config.lease_ttl_s))
        self.leases[robot] = lease
        return lease

    def release(self, client: str, robot: str) -> bool:
        if self.holder(robot) == client:
            del self.leases[robot]
            self.manual.pop(robot, None)
            return True
        return False

    def release_client(self, client: str) -> list[str]:
        """Drop every lease of a client that went away; its robots' manual commands stop at once."""
        robots = [r for r, lease in self.leases.items() if lease.client == client]
        for r in robots:
            del self.leases[r]
            self.manual.pop(r, None)
        return robots

    # ---- e-stop ---------------------------------------------------------------------------------------

    def estop(self, robot: str | None, reason: str) -> None:
        if robot is None:
            self.fleet_estop = reason
        else:
            self.estopped[robot] = reason
            self.manual.pop(robot, None)

    def rearm(self, robot: str | None) -> bool:
        if robot is None:
            was = self.fleet_estop is not None
            self.fleet_estop = None
            return was
        return self.estopped.pop(robot, None) is not None

    def is_estopped(self, robot: str) -> bool:
        return self.fleet_estop is not None or robot in self.estopped

    # ---- commands -------------------------------------------------------------------------------------

    def check_rate(self, client: str) -> None:
        now = time.monotonic()
        q = self._rates.setdefault(client, deque())
        while q and q[0] < now - 1.0:
            q.popleft()
        if len(q) >= self.config.max_command_rate_hz:
            raise FleetError(ErrorCode.BUSY, f"client '{client}' sent more than {self.config.max_command_rate_hz:g}"
                             " commands in the last second", "send fewer commands (the deadman allows renewal)")
        q.append(now)

    def manual_command(self, client: str, robot: str, v: float, w: float, limits: tuple[float, float], now: float,
                       duration: float | None = None) -> tuple[float, float, bool, str]:
        """Validate a manual velocity command; returns (v, w, clamped, reason) and stores it until its deadman
        (or `duration`) expires."""
        if not (math.isfinite(v) and math.isfinite(w)):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"velocity must be finite, got v={v}, w={w}")
        if self.is_estopped(robot):
            raise FleetError(ErrorCode.ESTOPPED, f"robot '{robot}' is e-stopped: {self.stop_reason(robot)}",
                             "re-arm it explicitly before commanding it")
        self.check_rate(client)
        self.acquire(client, robot)
        av, aw, clamped, reason = self.limit(v, w, limits)
        if clamped and self.config.strict:
            raise FleetError(ErrorCode.LIMIT_EXCEEDED, f"command rejected (strict mode): {reason}",
                             "stay within the robot's limits or disable strict mode")
        hold = self.config.deadman_s if duration is None else duration
        self.manual[robot] = ManualCommand(av, aw, now + hold, client)
        return av, aw, clamped, reason

    @staticmethod
    def limit(v: float, w: float, limits: tuple[float, float]) -> tuple[float, float, bool, str]:
        max_v, max_w = limits
        av, aw = max(-max_v, min(max_v, v)), max(-max_w, min(max_w, w))
        reasons = []
        if av != v:
            reasons.append(f"linear {v:.3g} m/s exceeds ±{max_v:.3g}")
        if aw != w:
            reasons.append(f"angular {w:.3g} rad/s exceeds ±{max_w:.3g}")
        return av, aw, bool(reasons), "; ".join(reasons)

    def active_manual(self, robot: str, now: float) -> ManualCommand | None:
        cmd = self.manual.get(robot)
        if cmd is not None and cmd.expires < now:
            del self.manual[robot]  # deadman: the command lapsed
            return None
        return cmd

    def stop_reason(self, robot: str) -> str:
        return self.fleet_estop or self.estopped.get(robot, "")

    def gate(self, robot: str, v: float, w: float, x: float, y: float, yaw: float) -> tuple[float, float, str]:
        """Final filter for every command: e-stop zeroes it; outside the geofence only motion back in is
        allowed. Returns (v, w, why-changed)."""
        if self.is_estopped(robot):
            return 0.0, 0.0, "e-stop"
        xmin, ymin, xmax, ymax = self.fence
        if not (xmin <= x <= xmax and ymin <= y <= ymax):
            # heading component toward the fence interior decides whether forward motion is allowed
            cx, cy = min(max(x, xmin), xmax) - x, min(max(y, ymin), ymax) - y
            inward = v * (math.cos(yaw) * cx + math.sin(yaw) * cy)
            if inward <= 0:
                return 0.0, w, "geofence"
        return v, w, ""
