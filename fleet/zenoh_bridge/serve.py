"""Serving a world over Zenoh until told to stop: the body of the CLI's `serve` command for the Zenoh door."""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING

from fleet.zenoh_bridge.bridge import ZenohBridge
from fleet.zenoh_config import ZenohConfig

if TYPE_CHECKING:
    from fleet.service import FleetService

log = logging.getLogger("fleetnav.zenoh")


def serve(service: FleetService, config: ZenohConfig, *, stop: threading.Event | None = None,
          clock: str = "realtime", speed: float = 1.0, on_ready: Callable[[list[str]], None] | None = None) -> None:
    """Start the service (if needed) and the bridge, and block until `stop` is set or Ctrl-C; `on_ready` gets
    the endpoints once agents can connect."""
    if not service.threaded:
        service.start(clock, speed)
    stop = stop or threading.Event()
    with ZenohBridge(service, config) as bridge:
        log.info("serving %s/** on %s", bridge.keys.base, ", ".join(config.listen) or "(peer discovery)")
        if on_ready is not None:
            on_ready(list(config.listen))
        try:
            while not stop.wait(0.5):
                pass
        except KeyboardInterrupt:
            log.info("interrupted: closing the Zenoh bridge")
