"""The agent SDK: write a robot controller in a few lines, in any process, on any machine that reaches the world.

    with Agent("me", connect="tcp/127.0.0.1:7447") as agent:
        r1 = agent.robot("r1")                      # subscribes to r1's odom, scan and pose
        scan = r1.wait("scan")                      # every message carries `stamp`, the sim time
        r1.drive(0.5, 0.0)                          # through the world's safety envelope (deadman: renew it)
        task = agent.navigate("r1", 5.0, 5.0)       # requests reply with the result or raise FleetError
        agent.wait_task(task["id"])

Lock-step (the world waits each control tick for this agent): `agent.lockstep(["r1"], step)` calls
`step(tick, stamp)` once per tick and sends the (v, w) it returns for each robot.

Leases: the first command takes the robot's lease, every command renews it; it lapses after the world's idle
expiry, on `agent.release("r1")`, or the moment this agent's session closes (its liveliness token disappears).
A background thread beats `heartbeat_hz` times a second: a world that misses 2 beats reports this agent as
`agent_unresponsive` (a hung process), while its deadman stops the robots.
"""

from __future__ import annotations

import json
import logging
import math
import queue
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable
from typing import Any

import numpy as np
import zenoh

from fleet.agent_link import CMD_QOS, RobotLink, direct_callback
from fleet.zenoh_api import Keys, check_name, decode_error, decode_grid, dumps
from fleet.zenoh_config import ZenohConfig
from sim.errors import ErrorCode, FleetError

Step = Callable[[int, float], dict[str, tuple[float, float]] | None]
log = logging.getLogger("fleetnav.agent")


class Agent:
    def __init__(self, agent_id: str, *, connect: str | list[str] | None = None, world: str | None = None,
                 config: ZenohConfig | None = None, timeout: float = 10.0, heartbeat_hz: float = 4.0) -> None:
        self.id = check_name("agent id", agent_id)
        if not (math.isfinite(heartbeat_hz) and 0 <= heartbeat_hz <= 100):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"heartbeat_hz must be in [0, 100], got {heartbeat_hz}",
                             "a few Hz is enough; 0 disables the heartbeat")
        self.heartbeat_hz = heartbeat_hz
        if config is None:
            eps = [connect] if isinstance(connect, str) else list(connect or [])
            config = ZenohConfig(mode="client" if eps else "peer", connect=eps, multicast_scouting=not eps)
        self.config, self.timeout, self._world = config, timeout, world
        self.sim_time = 0.0  # the latest stamp seen on any message
        self.events: deque[dict[str, Any]] = deque(maxlen=10_000)
        self.errors: deque[dict[str, Any]] = deque(maxlen=10_000)
        self._robots: dict[str, RobotLink] = {}
        self._event_cb: list[Callable[[dict[str, Any]], None]] = []
        self._cond = threading.Condition()
        self._ticks: queue.SimpleQueue[dict[str, Any]] | None = None  # the lock-step loop's inbox
        self._decls: list[Any] = []
        self._known: set[str] = set()  # robots the world reported (checked before linking)
        self._beat_stop = threading.Event()
        self._beat: threading.Thread | None = None
        self.unsynced = False  # velocity commands published since the last sync (close() syncs them)
        self.session: zenoh.Session

    def __enter__(self) -> Agent:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()

    def open(self) -> Agent:
        self.session = self._connect()
        try:
            self.keys = Keys(self._discover())
        except FleetError:
            self.session.close()
            raise
        k = self.keys
        self._decls = [
            self.session.declare_subscriber(k.fleet("events"), direct_callback(self._on_event)),
            self.session.declare_subscriber(k.agent_errors(self.id), direct_callback(self._on_error)),
            self.session.liveliness().declare_token(k.alive_agent(self.id)),
        ]
        if self.heartbeat_hz > 0:
            pub = self.session.declare_publisher(k.agent_heartbeat(self.id), encoding=zenoh.Encoding.APPLICATION_JSON,
                                                 congestion_control=zenoh.CongestionControl.DROP,
                                                 priority=zenoh.Priority.INTERACTIVE_HIGH, express=True)
            self._decls.insert(0, pub)
            self._beat_stop.clear()
            self._beat = threading.Thread(target=self._heartbeat, args=(pub,), name=f"fleetnav-heartbeat-{self.id}",
                                          daemon=True)
            self._beat.start()
        return self

    def _heartbeat(self, pub: zenoh.Publisher) -> None:
        period, seq = 1.0 / self.heartbeat_hz, 0
        while True:
            pub.put(dumps({"agent": self.id, "period": period, "seq": seq}))
            seq += 1
            if self._beat_stop.wait(period):
                return

    def sync(self, timeout: float | None = None) -> float:
        """Return once the world has applied (or rejected) every velocity command this agent published before the
        call; returns the world's sim time then. Velocity commands have no reply, and Zenoh may deliver the
        session's end before its last ones, so close() syncs first: a stop sent just before leaving is not dropped
        as late (fleet/command/sync goes on cmd_vel's priority, so it is ordered behind them on the link)."""
        msg = self.query(self.keys.command("sync"), {"agent": self.id}, timeout, **CMD_QOS)
        self.unsynced = False
        return float(msg["result"]["time"])

    def close(self) -> None:
        """Leave (after syncing any velocity command still in flight): the world releases this agent's leases as
        soon as its liveliness token disappears."""
        if self.unsynced:
            try:
                self.sync(timeout=min(self.timeout, 5.0))
            except FleetError as exc:  # the world is gone or busy: leave anyway, the commands may be dropped
                log.info("agent %s: closing without sync: %s", self.id, exc)
        self._beat_stop.set()
        if self._beat is not None:
            self._beat.join(timeout=2)
            self._beat = None
        for r in self._robots.values():
            r.close()
        for d in reversed(self._decls):
            d.undeclare()
        self.session.close()

    def _connect(self) -> zenoh.Session:
        """Open the session, retrying until `timeout` (a world started with `&` a moment ago may not listen yet)."""
        deadline = time.monotonic() + self.timeout
        while True:
            try:
                return zenoh.open(self.config.to_zenoh())
            except zenoh.ZError as exc:
                if time.monotonic() > deadline:
                    where = ", ".join(self.config.connect) or "(peer discovery)"
                    raise FleetError(ErrorCode.TIMEOUT, f"cannot reach a fleetnav world at {where} within "
                                     f"{self.timeout:g} s: {exc}", "start one: fleetnav zenoh --spawn r1") from exc
                time.sleep(0.2)

    def _discover(self) -> str:
        """The world's name from its liveliness token, retried until the link is up (or `timeout`)."""
        deadline = time.monotonic() + self.timeout
        pattern = Keys(self._world).alive_world() if self._world else Keys.worlds_pattern()
        while True:
            worlds = sorted({Keys.world_of(str(r.ok.key_expr)) for r in
                             self.session.liveliness().get(pattern, timeout=0.5) if r.ok is not None})
            if len(worlds) == 1:
                return worlds[0]
            if len(worlds) > 1:
                raise FleetError(ErrorCode.INVALID_ARGUMENT, f"several worlds answer: {', '.join(worlds)}",
                                 "pass world=<name>")
            if time.monotonic() > deadline:
                raise FleetError(ErrorCode.TIMEOUT, f"no fleetnav world found at {pattern} within {self.timeout:g} s",
                                 "is `fleetnav serve` running and the endpoint right?")

    def _saw(self, stamp: float) -> None:
        if stamp > self.sim_time:
            self.sim_time = stamp

    def _on_event(self, sample: zenoh.Sample) -> None:
        ev = json.loads(sample.payload.to_bytes())
        self._saw(ev["stamp"])
        with self._cond:
            self.events.append(ev)
            self._cond.notify_all()
        for cb in self._event_cb:
            cb(ev)

    def _on_error(self, sample: zenoh.Sample) -> None:
        err = json.loads(sample.payload.to_bytes())
        if self._ticks is not None and err.get("key") == self.keys.fleet("clock"):
            self._ticks.put({"hung": err})  # the world gave up on us: end the lock-step loop now
        with self._cond:
            self.errors.append(err)
            self._cond.notify_all()

    def on_event(self, callback: Callable[[dict[str, Any]], None]) -> None:
        """Call `callback(event)` for each fleet event (on Zenoh's thread: keep it short)."""
        self._event_cb.append(callback)

    def wait_for(self, predicate: Callable[[], bool], timeout: float = 10.0) -> bool:
        """Wait until `predicate()` holds; re-checked whenever an event or error arrives."""
        with self._cond:
            return self._cond.wait_for(predicate, timeout)

    # ---- robots and requests ------------------------------------------------------------------------------

    def robot(self, name: str, streams: Iterable[str] = ("odom", "scan", "pose"), *, check: bool = True) -> RobotLink:
        """Link to a robot; with `check`, an unknown robot is an UNKNOWN_ROBOT error listing the world's robots
        (instead of waiting for streams that never come)."""
        if name not in self._robots:
            check_name("robot", name)
            if check and name not in self._known:
                self._known = set(self.fleet_state()["names"])
                if name not in self._known:
                    listing = ", ".join(sorted(self._known)) or "(none)"
                    raise FleetError(ErrorCode.UNKNOWN_ROBOT, f"world '{self.keys.world}' has no robot '{name}' "
                                     f"(robots: {listing})", f"spawn it first: agent.spawn('{name}', x, y) or "
                                     f"`fleetnav zenoh --spawn {name}@x,y,yaw`")
            self._robots[name] = RobotLink(self, name, streams)
        return self._robots[name]

    def release(self, robot: str) -> bool:
        """Give the robot's lease back now (its current command stops); False if this agent did not hold it."""
        return bool(self.request("lease", robot=robot, release=True)["released"])

    def override(self, robot: str, reason: str = "operator override", hold_s: float | None = None) -> dict[str, Any]:
        """Operator: take the robot from whichever agent holds it (it stops; a `lease_override` event names the
        previous holder). Restrict who may do this with Zenoh access control on `fleet/command/override`."""
        return self.request("override", robot=robot, reason=reason, hold_s=hold_s)

    def query(self, key: str, payload: dict[str, Any] | None = None, timeout: float | None = None, **qos: Any) -> Any:
        """One reply from the world: its JSON on success, a FleetError raised on an error reply (`qos`: Zenoh's
        priority, express, congestion_control for the query)."""
        body = dumps(payload) if payload is not None else None
        for reply in self.session.get(key, payload=body, timeout=timeout or self.timeout, **qos):
            if reply.ok is not None:
                msg = json.loads(reply.ok.payload.to_bytes())
                self._saw(msg.get("stamp", 0.0))
                return msg
            assert reply.err is not None
            raise decode_error(reply.err.payload.to_bytes())
        raise FleetError(ErrorCode.TIMEOUT, f"no reply on {key}", "is the world still running?")

    def request(self, op: str, **fields: Any) -> Any:
        """A command with a reply (navigate, cancel, task_status, spawn, remove, reset, drive, lease, estop, ...)."""
        body = {k: v for k, v in fields.items() if v is not None} | {"agent": self.id}
        return self.query(self.keys.command(op), body)["result"]

    def navigate(self, robot: str, x: float, y: float, yaw: float = 0.0, align_yaw: bool = False) -> dict[str, Any]:
        return self.request("navigate", robot=robot, goal={"x": x, "y": y, "yaw": yaw}, align_yaw=align_yaw)

    def task_status(self, task_id: str) -> dict[str, Any]:
        return self.request("task_status", task_id=task_id)

    def cancel(self, task_id: str) -> dict[str, Any]:
        return self.request("cancel", task_id=task_id)

    def wait_task(self, task_id: str, timeout: float = 60.0) -> dict[str, Any]:
        """Until the task ends (succeeded, failed or canceled); re-checks whenever a fleet event arrives."""
        deadline = time.monotonic() + timeout
        while True:
            status = self.task_status(task_id)
            if status["state"] in ("succeeded", "failed", "canceled"):
                return status
            seen = len(self.events)
            if time.monotonic() > deadline:
                raise FleetError(ErrorCode.TIMEOUT, f"task {task_id} still {status['state']} after {timeout:g} s")
            self.wait_for(lambda n=seen: len(self.events) != n, timeout=0.5)  # type: ignore[misc]

    def spawn(self, name: str, x: float, y: float, yaw: float = 0.0, **kw: Any) -> dict[str, Any]:
        return self.request("spawn", name=name, pose={"x": x, "y": y, "yaw": yaw}, **kw)

    def reset(self) -> dict[str, Any]:
        return self.request("reset")

    def fleet_state(self) -> dict[str, Any]:
        return self.query(self.keys.fleet("state"))

    def tasks(self, robot: str | None = None, include_done: bool = False) -> list[dict[str, Any]]:
        body = {"include_done": include_done} | ({"robot": robot} if robot else {})
        return self.query(self.keys.fleet("tasks"), body)["result"]

    def occupancy_map(self) -> tuple[np.ndarray, float, tuple[float, float]]:
        """(int8 grid with row 0 at the bottom, resolution m, origin of cell (0, 0) in the map frame)."""
        d = self.query(self.keys.fleet("map"))
        return decode_grid(d), d["resolution"], (d["origin"]["x"], d["origin"]["y"])

    # ---- lock-step ----------------------------------------------------------------------------------------

    def lockstep(self, robots: list[str], step: Step, *, max_ticks: int | None = None,
                 tick_timeout: float = 30.0) -> int:
        """Answer every control tick: `step(tick, stamp)` returns {robot: (v, w)} (missing robots get (0, 0)),
        or None to leave lock-step (the robots' last commands hold until the deadman unless stopped). Returns the
        number of ticks answered."""
        ticks: queue.SimpleQueue[dict[str, Any]] = queue.SimpleQueue()
        self._ticks = ticks
        links = [self.robot(r) for r in robots]
        clock = self.session.declare_subscriber(self.keys.fleet("clock"),
                                                direct_callback(lambda s: ticks.put(json.loads(s.payload.to_bytes()))))
        n = 0
        try:
            self.request("lockstep", robots=robots)
        except FleetError:
            clock.undeclare()
            raise
        try:
            while max_ticks is None or n < max_ticks:
                try:
                    msg = ticks.get(timeout=tick_timeout)
                except queue.Empty:
                    raise FleetError(ErrorCode.TIMEOUT, f"no lock-step tick for {tick_timeout:g} s",
                                     "is the world paused?") from None
                if "hung" in msg:
                    raise decode_error(dumps(msg["hung"]))
                self._saw(msg["stamp"])
                cmds = step(msg["tick"], msg["stamp"])
                if cmds is None:  # done: leave without answering, so the world waits and ends at this very tick
                    break
                for link in links:
                    v, w = cmds.get(link.name, (0.0, 0.0))
                    link.drive(v, w, tick=msg["tick"])
                n += 1
        finally:
            clock.undeclare()
            self._ticks = None
            self.request("lockstep", robots=[])
        return n
