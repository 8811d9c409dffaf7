"""The Zenoh front door (server side): `ZenohBridge(service, config)` over a FleetService in service mode.

The key-expression scheme and payloads live in fleet.zenoh_api; the client SDK is fleet.agent.
"""

from fleet.zenoh_bridge.bridge import ZenohBridge
from fleet.zenoh_bridge.serve import serve

__all__ = ["ZenohBridge", "serve"]
