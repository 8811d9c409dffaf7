"""Live view: a Foxglove WebSocket server (foxglove-sdk) carrying the same channels as a recording.

Open Foxglove (app or https://app.foxglove.dev), "Open connection" → Foxglove WebSocket →
ws://localhost:8765, then import the layout configs/foxglove_layout.json (map, robots, scans, paths,
camera). `fleetnav run --live` paces the mission at real time so it can be watched; a service front door
(`fleetnav serve --live`) calls `LiveView().attach(service)` once the service is built.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import foxglove

from fleet.recording.publisher import FoxglovePublisher

if TYPE_CHECKING:
    from fleet.service import FleetService

DEFAULT_PORT = 8765


class LiveView:
    def __init__(self, host: str = "127.0.0.1", port: int = DEFAULT_PORT, *, camera_robot: str | None = None,
                 name: str = "fleetnav") -> None:
        self.host, self.port, self.name = host, port, name
        self.camera_robot = camera_robot
        self._server: Any = None
        self._publisher: FoxglovePublisher | None = None

    def open(self, context: foxglove.Context) -> None:
        """Serve an existing context (the MCAP recorder's), so the live view and the file match."""
        self._server = foxglove.start_server(name=self.name, host=self.host, port=self.port, context=context)

    def attach(self, svc: FleetService, mission_yaml: str = "", seed: int = 0) -> LiveView:
        """Serve a service on its own context (publishing happens on the sim thread, after each control tick).
        With the extra arguments it is a Recorder, for runs that show live but record nothing."""
        ctx = foxglove.Context()
        self.open(ctx)
        self._publisher = FoxglovePublisher(svc, ctx, camera_robot=self.camera_robot)
        return self

    @property
    def url(self) -> str:
        port = self._server.port if self._server is not None else self.port
        return f"ws://{self.host}:{port}"

    def close(self) -> dict[str, int]:
        counts: dict[str, int] = {}
        if self._publisher is not None:
            self._publisher.close()
            counts = dict(sorted(self._publisher.counts.items()))
            self._publisher = None
        if self._server is not None:
            self._server.stop()
            self._server = None
        return counts
