"""One robot as an agent sees it (fleet.agent's `agent.robot(name)`): the latest message of each stream, and
velocity commands."""

from __future__ import annotations

import json
import math
import threading
import time
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, Any

import zenoh

from fleet.zenoh_api import Odom, PoseStamped, Scan, decode_odom, decode_pose, decode_scan, dumps
from sim.errors import ErrorCode, FleetError

if TYPE_CHECKING:
    from fleet.agent import Agent

# Velocity commands' QoS; agent.sync() sends its barrier with the same, so it is ordered behind them on the link.
CMD_QOS: dict[str, Any] = {"priority": zenoh.Priority.INTERACTIVE_HIGH, "express": True,
                           "congestion_control": zenoh.CongestionControl.BLOCK}
DECODERS: dict[str, Callable[[bytes], Any]] = {"odom": decode_odom, "scan": decode_scan, "pose": decode_pose,
                                               "state": json.loads, "imu": json.loads}


def direct_callback(fn: Callable[[Any], Any]) -> zenoh.handlers.Callback[Any]:
    # On Zenoh's receiving thread: messages stay in the order the world sent them (lock-step relies on it).
    return zenoh.handlers.Callback(fn, indirect=False)


class RobotLink:
    """One robot as this agent sees it: the latest message of each stream, and commands."""

    def __init__(self, agent: Agent, name: str, streams: Iterable[str]) -> None:
        self.agent, self.name = agent, name
        self.latest: dict[str, Any] = {}
        self._cond = threading.Condition()
        self._seq = 0
        keys = agent.keys
        self._cmd = agent.session.declare_publisher(keys.robot(name, "cmd_vel"),
                                                    encoding=zenoh.Encoding.APPLICATION_JSON, **CMD_QOS)
        self._subs = [agent.session.declare_subscriber(keys.robot(name, s), direct_callback(self._receiver(s)))
                      for s in streams]

    def _receiver(self, stream: str) -> Callable[[zenoh.Sample], None]:
        decode = DECODERS[stream]

        def receive(sample: zenoh.Sample) -> None:
            msg = decode(sample.payload.to_bytes())
            self.agent._saw(msg["stamp"] if isinstance(msg, dict) else msg.stamp)
            with self._cond:
                self.latest[stream] = msg
                self._cond.notify_all()

        return receive

    @property
    def odom(self) -> Odom | None:
        return self.latest.get("odom")

    @property
    def scan(self) -> Scan | None:
        return self.latest.get("scan")

    @property
    def pose(self) -> PoseStamped | None:
        return self.latest.get("pose")

    def wait(self, stream: str = "scan", timeout: float = 10.0, newer_than: float = -math.inf) -> Any:
        """The latest message of `stream` stamped after `newer_than` (sim s), waiting up to `timeout` wall s."""
        def ready() -> bool:
            m = self.latest.get(stream)
            return m is not None and (m["stamp"] if isinstance(m, dict) else m.stamp) > newer_than

        with self._cond:
            if not self._cond.wait_for(ready, timeout):
                raise FleetError(ErrorCode.TIMEOUT, f"no '{stream}' from robot '{self.name}' within {timeout:g} s",
                                 "is the robot spawned, the stream enabled, the world running?")
            return self.latest[stream]

    def drive(self, v: float, w: float, *, tick: int | None = None, duration: float | None = None) -> None:
        """Publish a velocity command (no reply: rejections arrive in `agent.errors`)."""
        self._seq += 1
        msg: dict[str, Any] = {"v": v, "w": w, "agent": self.agent.id, "seq": self._seq, "sent": time.time()}
        if tick is not None:
            msg["tick"] = tick
        if duration is not None:
            msg["duration"] = duration
        self._cmd.put(dumps(msg))
        self.agent.unsynced = True

    def drive_sync(self, v: float, w: float, duration: float | None = None) -> dict[str, Any]:
        """A velocity command with a reply: what was applied after clamping, or a FleetError (e.g. LEASE_HELD)."""
        return self.agent.request("drive", robot=self.name, v=v, w=w, duration=duration)

    def stop(self) -> None:
        self.drive(0.0, 0.0)

    def close(self) -> None:
        for s in self._subs:
            s.undeclare()
        self._cmd.undeclare()
