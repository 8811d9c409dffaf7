"""ZenohBridge: the Zenoh front door over one FleetService in service mode.

It declares, under `fleetnav/@v1/<world>/` (fleet.zenoh_api.Keys): per-robot sensor and state publishers and the
fleet-level state (Streams), the `cmd_vel` subscriber and the queryables (Commands), the events/errors outbox,
the lock-step clock (Gate), and liveliness: a token for the world and one per robot, and a subscriber on the
agents' tokens — an agent whose token disappears (its session closed, even right after a command) loses its
leases, its robots stop at once and its commands still in flight are dropped. The agents' heartbeats go to the
Watchdog, which reports a hung agent (`agent_unresponsive`) separately from the deadman that stops its robots.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any

import zenoh

from fleet import cdr
from fleet.types import Event, FleetSnapshot
from fleet.zenoh_api import Keys, RosKeys, dumps, encode_error, encode_event
from fleet.zenoh_bridge.commands import Commands
from fleet.zenoh_bridge.gate import Gate
from fleet.zenoh_bridge.outbox import Outbox
from fleet.zenoh_bridge.streams import Streams
from fleet.zenoh_bridge.watchdog import Watchdog
from fleet.zenoh_config import ZenohConfig
from sim.errors import ErrorCode, FleetError

if TYPE_CHECKING:
    from fleet.service import FleetService

log = logging.getLogger("fleetnav.zenoh")


def _direct(fn: Any) -> zenoh.handlers.Callback[Any]:
    """Run the callback on Zenoh's receiving thread: samples of one link keep their order (lock-step needs it)."""
    return zenoh.handlers.Callback(fn, indirect=False)


class ZenohBridge:
    def __init__(self, service: FleetService, config: ZenohConfig | None = None) -> None:
        self.service = service
        self.config = config or ZenohConfig()
        self.keys = Keys(self.config.world_key or service.world.name)
        self.session: zenoh.Session | None = None
        self.agents: set[str] = set()  # agents whose liveliness token is up
        self._robot_tokens: dict[str, zenoh.LivelinessToken] = {}
        self._decls: list[Any] = []
        self._unsubscribe: list[Any] = []

    def __enter__(self) -> ZenohBridge:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    def start(self) -> ZenohBridge:
        svc, cfg, k = self.service, self.config, self.keys
        if not svc.threaded:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, "the Zenoh bridge needs the service in service mode",
                             "call service.start(...) first: agents act in wall time, batch stepping has no sim thread")
        cfg.check_rates(svc.config.control_hz)
        self.session = s = zenoh.open(cfg.to_zenoh())
        self.outbox = Outbox(s)
        self.watchdog = Watchdog(k, self._on_watchdog)
        self.gate = Gate(svc, lockstep=cfg.lockstep.enabled, timeout_s=cfg.lockstep.timeout_s,
                         on_tick=self._publish_clock, on_hung=self._hung)
        self.ros = RosKeys(cfg.ros2.prefix) if cfg.ros2.enabled else None
        self.streams = Streams(s, k, cfg.streams, self.ros, odom_hz=cfg.odom_hz, state_hz=cfg.state_hz)
        self.commands = Commands(svc, self.gate, k, self._report, workers=cfg.query_workers,
                                 lockstep=cfg.lockstep.enabled, ros_client=cfg.ros2.client,
                                 on_register=lambda: self._on_snapshot(svc.snapshot), budget=cfg.query_budget_s)
        self._clock = s.declare_publisher(k.fleet("clock"), encoding=zenoh.Encoding.APPLICATION_JSON,
                                          congestion_control=zenoh.CongestionControl.BLOCK)
        self._decls += [
            self._clock,
            s.declare_subscriber(k.robot_any("cmd_vel"), _direct(self.commands.on_cmd_vel)),
            s.declare_queryable(k.command("*"), _direct(self.commands.on_query)),
            s.declare_queryable(k.robot_any("camera"), _direct(self.commands.on_query)),
            *[s.declare_queryable(k.fleet(t), _direct(self.commands.on_query)) for t in ("state", "map", "tasks")],
            s.liveliness().declare_subscriber(k.alive_agent("*"), _direct(self._on_agent), history=True),
            s.declare_subscriber(k.agent_heartbeat("*"), _direct(self.watchdog.on_beat)),
            s.liveliness().declare_token(k.alive_world()),
        ]
        if self.ros is not None:
            self._decls.append(s.declare_subscriber(self.ros.topic("*", "cmd_vel"), _direct(self._on_ros_twist)))
        svc.call(self._install)
        log.info("zenoh bridge up: %s/** (lock-step %s)", k.base, "on" if cfg.lockstep.enabled else "off")
        return self

    def close(self) -> None:
        if self.session is None:
            return
        self.gate.run(self.gate.agents.clear)  # a world waiting on lock-step agents stops waiting
        self.watchdog.close()
        if self.service.threaded:
            self.service.call(self._uninstall)
        else:
            self._uninstall()
        self.commands.close()
        for d in reversed(self._decls):
            d.undeclare()
        for t in self._robot_tokens.values():
            t.undeclare()
        self._robot_tokens.clear()
        self.outbox.close()
        self.streams.close()
        self.session.close()
        self.session = None

    # ---- hooks into the service (installed and removed on the sim thread) ------------------------------------

    def _install(self) -> None:
        svc = self.service
        self._apply_policy()
        self._subscribe_world()
        svc.tick_listeners.append(self._on_snapshot)
        svc.control_gate = self.gate
        svc.step_listeners.append(self.gate.stepped)
        self._unsubscribe.append(svc.events.subscribe(self._on_event))
        for name in svc.world.robot_names():
            self._robot_up(name)

    def _uninstall(self) -> None:
        svc = self.service
        svc.safety.config = svc.config.safety  # the agents' policy was this bridge's
        for unsub in self._unsubscribe:
            unsub()
        self._unsubscribe.clear()
        if self._on_snapshot in svc.tick_listeners:
            svc.tick_listeners.remove(self._on_snapshot)
        if svc.control_gate is self.gate:
            svc.control_gate = None
        if self.gate.stepped in svc.step_listeners:
            svc.step_listeners.remove(self.gate.stepped)

    def _apply_policy(self) -> None:
        """Sim thread: the config's lease and rate policy over the fleet's (again after a reset rebuilds the
        safety envelope)."""
        if policy := self.config.agents.safety_update():
            self.service.safety.config = self.service.config.safety.model_copy(update=policy)

    def _subscribe_world(self) -> None:
        st = self.config.streams
        kinds = [k for k, on in (("odom", st.odom), ("scan", st.scan), ("imu", st.imu)) if on]
        if kinds:
            self._unsubscribe.append(self.service.world.subscribe(self.streams.on_reading, kinds=kinds))

    def _on_snapshot(self, snap: FleetSnapshot) -> None:
        self.streams.on_snapshot(snap, self.gate.tick_of(snap.step_count))

    def _on_event(self, ev: Event) -> None:
        """Every service event goes out on `fleet/events`; world changes also update streams and tokens."""
        assert self.session is not None
        self.outbox.put(self.keys.fleet("events"), encode_event(ev))
        if ev.kind in ("reset", "world_loaded"):  # on the sim thread, the new world already built
            self.gate.forget_ticks()
            self._apply_policy()
            for name in list(self._robot_tokens):
                self._robot_down(name)
            self._subscribe_world()
        elif ev.kind == "robot_spawned":
            for name in ev.robots:
                self._robot_up(name)
        elif ev.kind == "robot_removed":
            for name in ev.robots:
                self._robot_down(name)

    def _robot_up(self, name: str) -> None:
        self.streams.add_robot(name)
        assert self.session is not None
        token_key = self.keys.alive_robot(name)
        liveliness = self.session.liveliness()
        self.outbox.do(lambda: self._robot_tokens.__setitem__(name, liveliness.declare_token(token_key)))

    def _robot_down(self, name: str) -> None:
        self.streams.remove_robot(name)
        self.outbox.do(lambda: (t.undeclare() if (t := self._robot_tokens.pop(name, None)) is not None else None))

    # ---- agents: liveliness, lock-step clock, hung agents, error reports ----------------------------------------

    def _on_agent(self, sample: zenoh.Sample) -> None:
        agent = Keys.last(str(sample.key_expr))
        svc = self.service
        if sample.kind == zenoh.SampleKind.PUT:
            self.agents.add(agent)

            def joined() -> None:  # sim thread
                svc.safety.client_joined(agent)
                svc.events.publish(svc.world.time, "agent_joined", message=agent, agent=agent)

            self.gate.run(joined)
            return
        self.agents.discard(agent)
        self.watchdog.forget(agent)

        def lost() -> None:  # sim thread; a command of this agent still queued behind us is now dropped
            svc.safety.client_left(agent)
            self.gate.unregister(agent)
            self.commands.forget_agent(agent)
            robots = svc.release_client(agent, "its liveliness token disappeared")  # stops them, client_lost
            svc.events.publish(svc.world.time, "agent_left", robots, f"agent '{agent}' is gone", agent=agent)

        self.gate.run(lost)

    def _on_watchdog(self, agent: str, silent: float, period: float, responsive: bool) -> None:
        svc = self.service

        def report() -> None:  # sim thread: the robots it holds right now
            robots = svc.safety.robots_of(agent)
            if responsive:
                svc.events.publish(svc.world.time, "agent_responsive", robots, f"agent '{agent}' beats again",
                                   agent=agent)
                return
            listed = ", ".join(robots) if robots else "no robots"
            svc.events.publish(svc.world.time, "agent_unresponsive", robots,
                               f"agent '{agent}' missed its heartbeats: silent for {silent:.2f} s (period "
                               f"{period:.2f} s); it holds {listed}, which the deadman stops",
                               agent=agent, silent_s=round(silent, 3), heartbeat_period_s=period)

        self.gate.run(report)

    def _publish_clock(self, tick: int, now: float) -> None:
        self._clock.put(dumps({"stamp": now, "tick": tick, "control_period": 1.0 / self.service.config.control_hz}))

    def _hung(self, agent: str, robots: list[str]) -> None:
        svc = self.service
        self._report(FleetError(ErrorCode.TIMEOUT, f"no command for lock-step tick within {self.gate.timeout_s:g} s: "
                                "declared hung, robots stopped", "register again to rejoin"),
                     self.keys.fleet("clock"), agent)
        stopped = svc.release_client(agent, "hung in lock-step")
        svc.events.publish(svc.world.time, "agent_hung", robots, f"agent '{agent}' did not answer a lock-step tick "
                           f"within {self.gate.timeout_s:g} s; its robots were stopped", agent=agent, stopped=stopped)

    def _report(self, exc: FleetError, key: str, agent: str | None) -> None:
        payload = encode_error(exc, self.service.snapshot.time, key=key, agent=agent)
        self.outbox.put(self.keys.fleet("errors"), payload)
        if agent is not None:
            self.outbox.put(self.keys.agent_errors(agent), payload)

    def _on_ros_twist(self, sample: zenoh.Sample) -> None:
        key = str(sample.key_expr)
        assert self.ros is not None
        try:
            t = cdr.decode_twist(sample.payload.to_bytes())
        except FleetError as exc:
            self.commands.malformed()
            log.warning("malformed ROS 2 Twist on %s rejected: %s", key, exc)
            self._report(exc, key, None)
            return
        self.commands.on_ros_twist(self.ros.robot_of(key), key, t.linear[0], t.angular[2])

    def stats(self) -> dict[str, Any]:
        return {"commands": self.commands.stats.to_dict(), "latency": self.gate.latency_stats(),
                "published": self.streams.published, "gate_ticks": self.gate.ticks, "agents": sorted(self.agents),
                "unresponsive_reports": self.watchdog.reported,
                "lockstep_agents": sorted(self.gate.agents)}
