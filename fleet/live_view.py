"""Live view: a Foxglove WebSocket server (foxglove-sdk) carrying the same channels as a recording.

Open Foxglove (app or https://app.foxglove.dev), "Open connection" → Foxglove WebSocket →
ws://localhost:8765, then import the layout configs/foxglove_layout.json (map, robots, scans, paths,
camera). `fleetnav run --live` paces the mission at real time so it can be watched; a service front door
(`fleetnav serve --live`, `fleetnav zenoh --live`) calls `LiveView().attach(service)` once the service is built.

Static data reaches viewers that join late: when a viewer subscribes to `/map` the map is sent again (at the
next control tick), and `/fleetnav/robots` (each robot's model, namespace and full description) is re-sent to
it at once — the "latched" topics of ROS.
"""

from __future__ import annotations

import json
import threading
from typing import TYPE_CHECKING, Any

import foxglove
from foxglove.websocket import ChannelView, Client, ServerListener

from fleet.recording.publisher import FoxglovePublisher
from fleet.types import Event

if TYPE_CHECKING:
    from fleet.service import FleetService

DEFAULT_PORT = 8765
ROBOTS_TOPIC = "/fleetnav/robots"
ROBOT_EVENTS = ("robot_spawned", "robot_removed", "reset", "world_loaded")


class _Latch(ServerListener):
    """Re-sends static topics to a viewer that subscribes to them (the foxglove server's thread)."""

    def __init__(self, view: LiveView) -> None:
        self.view = view

    def on_subscribe(self, client: Client, channel: ChannelView) -> None:
        self.view.resend(channel.topic)


class LiveView:
    def __init__(self, host: str = "127.0.0.1", port: int = DEFAULT_PORT, *, camera_robot: str | None = None,
                 name: str = "fleetnav") -> None:
        self.host, self.port, self.name = host, port, name
        self.camera_robot = camera_robot
        self._server: Any = None
        self._publisher: FoxglovePublisher | None = None
        self._robots: foxglove.Channel | None = None
        self._robots_msg: str | None = None  # the latest robot descriptions, JSON
        self._lock = threading.Lock()
        self._unsubscribe: Any = None
        self.resent: dict[str, int] = {}  # topic → times re-sent to a late subscriber

    def open(self, context: foxglove.Context) -> None:
        """Serve an existing context (the MCAP recorder's), so the live view and the file match."""
        self._server = foxglove.start_server(name=self.name, host=self.host, port=self.port, context=context,
                                             server_listener=_Latch(self))

    def adopt(self, publisher: FoxglovePublisher) -> None:
        """Serving a recorder's context (`open`): its publisher re-sends /map to late viewers."""
        self._publisher = publisher

    def attach(self, svc: FleetService, mission_yaml: str = "", seed: int = 0) -> LiveView:
        """Serve a service on its own context (publishing happens on the sim thread, after each control tick).
        With the extra arguments it is a Recorder, for runs that show live but record nothing."""
        ctx = foxglove.Context()
        self._publisher = FoxglovePublisher(svc, ctx, camera_robot=self.camera_robot)
        self._robots = foxglove.Channel(ROBOTS_TOPIC, message_encoding="json", context=ctx)
        self._unsubscribe = svc.events.subscribe(lambda ev: self._on_robots(svc, ev), kinds=ROBOT_EVENTS)
        if svc.threaded:
            svc.call(lambda: self._describe(svc))
        else:
            self._describe(svc)
        self.open(ctx)
        return self

    def _on_robots(self, svc: FleetService, ev: Event) -> None:
        self._describe(svc)

    def _describe(self, svc: FleetService) -> None:
        """Sim thread: every robot's description, logged now and kept for late subscribers."""
        robots = []
        for name in svc.world.robot_names():
            rec = svc.registry.get(name)
            robots.append({"name": name, "model": rec.model, "namespace": rec.namespace, "fidelity": rec.fidelity,
                           "description": svc.world.robot_spec(name).model_dump(mode="json")})
        msg = json.dumps({"stamp": svc.world.time, "world": svc.world.name, "robots": robots})
        with self._lock:
            self._robots_msg = msg
        if self._robots is not None:
            self._robots.log(msg)

    def resend(self, topic: str) -> None:
        """A viewer subscribed to `topic`: static data goes out again (the map at the next control tick)."""
        if topic == "/map" and self._publisher is not None:
            self._publisher.resend_map()
        elif topic == ROBOTS_TOPIC and self._robots is not None:
            with self._lock:
                msg = self._robots_msg
            if msg is not None:
                self._robots.log(msg)
        else:
            return
        self.resent[topic] = self.resent.get(topic, 0) + 1

    @property
    def url(self) -> str:
        port = self._server.port if self._server is not None else self.port
        return f"ws://{self.host}:{port}"

    def close(self) -> dict[str, int]:
        counts: dict[str, int] = {}
        if self._unsubscribe is not None:
            self._unsubscribe()
            self._unsubscribe = None
        if self._publisher is not None and self._robots is not None:  # attach(): the publisher is ours
            self._publisher.close()
            counts = dict(sorted(self._publisher.counts.items()))
        self._publisher, self._robots = None, None
        if self._server is not None:
            self._server.stop()
            self._server = None
        return counts
