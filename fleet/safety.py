"""The safety envelope: the one chokepoint every velocity command goes through, from every front door.

Limits (clamp, or reject in strict mode, saying which), a deadman on manual commands (sim time), a latched
e-stop per robot or for the fleet with explicit re-arm, a geofence, one controlling client per robot (a lease
renewed by the holder's commands, lapsing after `lease_idle_s` of silence, released at once when a front door
reports the client gone, taken by an operator override), and command rate limits per robot and per client
(see fleet.leases.RateWindow).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

from pydantic import Field

from fleet.leases import Departed, Lease, RateWindow
from sim.config import StrictModel
from sim.errors import ErrorCode, FleetError

AUTONOMY = "fleet"  # the client id tasks and behaviours act under


class SafetyConfig(StrictModel):
    strict: bool = Field(False, description="reject commands past the limits instead of clamping them")
    deadman_s: float = Field(0.5, gt=0, description="a manual velocity command expires after this (sim s)")
    lease_idle_s: float = Field(3.0, gt=0, le=3600,
                                description="a lease lapses this long after its holder's last command (wall s)")
    robot_rate_hz: float | None = Field(None, gt=0, description="accepted commands per second per robot "
                                        "(sim and wall time); null: 4 × the control rate")
    agent_rate_hz: float = Field(5000.0, gt=0, description="accepted commands per second per client: a "
                                 "ceiling sized for a fleet controller driving every robot")
    geofence: tuple[float, float, float, float] | None = Field(
        None, description="(xmin, ymin, xmax, ymax); null: the world's bounds")
    geofence_margin: float = Field(0.5, ge=0, description="metres added around the world's bounds")


@dataclass(frozen=True)
class ManualCommand:
    v: float
    w: float
    expires: float  # sim time
    client: str


class SafetyEnvelope:
    def __init__(self, config: SafetyConfig, bounds: tuple[float, float, float, float], *,
                 control_hz: float = 10.0) -> None:
        self.config = config
        self.control_hz = control_hz
        b = config.geofence or bounds
        m = 0.0 if config.geofence else config.geofence_margin
        self.fence = (b[0] - m, b[1] - m, b[2] + m, b[3] + m)
        self.estopped: dict[str, str] = {}  # robot → reason
        self.fleet_estop: str | None = None
        self.leases: dict[str, Lease] = {}
        self.manual: dict[str, ManualCommand] = {}
        self.departed = Departed()
        self._robot_rates, self._client_rates = RateWindow(), RateWindow()

    # ---- leases ---------------------------------------------------------------------------------------

    def holder(self, robot: str) -> str | None:
        lease = self.leases.get(robot)
        if lease is None or lease.expires < time.monotonic():
            self.leases.pop(robot, None)
            return None
        return lease.client

    def check_lease(self, client: str, robot: str) -> None:
        """Raise unless `client` may command `robot` now (LEASE_HELD names the holder)."""
        if client in self.departed:
            raise FleetError(ErrorCode.NOT_FOUND, f"client '{client}' has left (its session closed); its command "
                             f"for robot '{robot}' arrived late and is dropped", "reconnect to command again")
        holder = self.holder(robot)
        if holder is not None and holder != client:
            lease = self.leases[robot]
            idle = lease.idle_s - (lease.expires - time.monotonic())
            raise FleetError(ErrorCode.LEASE_HELD, f"robot '{robot}' is controlled by client '{holder}' (last "
                             f"command {idle:.2f} s ago; the lease lapses after {lease.idle_s:g} s idle)",
                             "wait for it to lapse, ask that client to release it, or use an operator override")

    def acquire(self, client: str, robot: str, ttl: float | None = None) -> Lease:
        """Take or renew the lease (idle expiry `ttl`, default lease_idle_s); LEASE_HELD names the holder."""
        self.check_lease(client, robot)
        lease = self.leases.get(robot)
        if lease is None or lease.client != client or ttl is not None:
            lease = self.leases[robot] = Lease(client, ttl or self.config.lease_idle_s)
        else:
            lease.renew()
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

    def client_left(self, client: str) -> None:
        """The client's session is gone: its commands still in flight are dropped (release its leases too)."""
        self.departed.mark(client)
        self._client_rates.forget(client)

    def client_joined(self, client: str) -> None:
        self.departed.clear(client)

    def override(self, operator: str, robot: str, ttl: float | None = None) -> str | None:
        """An operator takes the robot from whoever holds it (its manual command stops); returns the previous
        holder."""
        previous = self.holder(robot)
        self.manual.pop(robot, None)
        self.leases[robot] = Lease(operator, ttl or self.config.lease_idle_s)
        return previous

    def robots_of(self, client: str) -> list[str]:
        return sorted(r for r in list(self.leases) if self.holder(r) == client)

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

    @property
    def robot_rate_limit(self) -> float:
        return self.config.robot_rate_hz or 4.0 * self.control_hz

    def check_rate(self, client: str, robot: str, now: float) -> None:
        """Reject a command past the per-robot or per-client rate (`now`: sim time; a command counts while it is
        under a second old in sim and in wall time), naming the limit and the current rate."""
        wall = time.monotonic()
        n_robot, lim_robot = self._robot_rates.count(robot, now, wall), self.robot_rate_limit
        if n_robot + 1 > lim_robot:
            raise FleetError(ErrorCode.BUSY, f"robot '{robot}': rate limit {lim_robot:g} commands/s per robot "
                             f"(safety.robot_rate_hz) reached, current rate {n_robot}/s",
                             f"one command per control tick ({self.control_hz:g} Hz) is enough; the deadman "
                             f"holds a command for {self.config.deadman_s:g} s")
        n_client, lim_client = self._client_rates.count(client, now, wall), self.config.agent_rate_hz
        if n_client + 1 > lim_client:
            raise FleetError(ErrorCode.BUSY, f"client '{client}': rate limit {lim_client:g} commands/s "
                             f"per client (safety.agent_rate_hz) reached, current rate {n_client}/s",
                             "raise safety.agent_rate_hz for a larger fleet controller")
        self._robot_rates.add(robot, now, wall)
        self._client_rates.add(client, now, wall)

    def manual_command(self, client: str, robot: str, v: float, w: float, limits: tuple[float, float], now: float,
                       duration: float | None = None) -> tuple[float, float, bool, str]:
        """Validate a manual velocity command; returns (v, w, clamped, reason) and stores it until its deadman
        (or `duration`) expires."""
        if not (math.isfinite(v) and math.isfinite(w)):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"velocity must be finite, got v={v}, w={w}")
        if self.is_estopped(robot):
            raise FleetError(ErrorCode.ESTOPPED, f"robot '{robot}' is e-stopped: {self.stop_reason(robot)}",
                             "re-arm it explicitly before commanding it")
        self.check_lease(client, robot)  # a refused client does not use up the robot's rate
        self.check_rate(client, robot, now)
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
