"""McapRecorder: the fleet's Foxglove channels written to an MCAP file (foxglove-sdk writer, own Context).

The mission YAML actually run and each robot's spawn pose go into MCAP metadata records, so a recording
is enough to replay the run (fleet.recording.replay). With `live`, the same Context also feeds a Foxglove
WebSocket server: the live view shows exactly what is recorded.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

import foxglove

from fleet.recording.publisher import FoxglovePublisher
from fleet.recording.types import MISSION_METADATA, SPAWN_METADATA

if TYPE_CHECKING:
    from fleet.live_view import LiveView
    from fleet.service import FleetService


class McapRecorder:
    def __init__(self, path: str | Path, *, scans: bool = True, markers_hz: float = 2.0,
                 camera_robot: str | None = None, camera_hz: float = 1.0, live: LiveView | None = None) -> None:
        self.path = Path(path)
        self._opts = {"scans": scans, "markers_hz": markers_hz, "camera_robot": camera_robot, "camera_hz": camera_hz}
        self._live = live
        self._writer: foxglove.mcap.MCAPWriter | None = None
        self._publisher: FoxglovePublisher | None = None

    def attach(self, svc: FleetService, mission_yaml: str, seed: int) -> None:
        ctx = foxglove.Context()
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._writer = foxglove.open_mcap(self.path, allow_overwrite=True, context=ctx)
        self._writer.write_metadata(MISSION_METADATA, {"yaml": mission_yaml, "seed": str(seed)})
        spawn = {n: {"pose": list(svc.world.robot_pose(n).as_tuple()), "fidelity": svc.world.robot_fidelity(n),
                     "model": svc.registry.get(n).model, "namespace": svc.registry.get(n).namespace}
                 for n in svc.world.robot_names()}
        self._writer.write_metadata(SPAWN_METADATA, {"robots": json.dumps(spawn)})
        if self._live is not None:
            self._live.open(ctx)
        self._publisher = FoxglovePublisher(svc, ctx, **self._opts)  # type: ignore[arg-type]
        if self._live is not None:
            self._live.adopt(self._publisher)  # a late viewer gets /map again

    def close(self) -> dict[str, int]:
        counts: dict[str, int] = {}
        if self._publisher is not None:
            self._publisher.close()
            counts = dict(sorted(self._publisher.counts.items()))
        if self._writer is not None:
            self._writer.close()
        if self._live is not None:
            self._live.close()
        self._writer = self._publisher = None
        return counts
