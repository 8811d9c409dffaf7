"""Reading fleetnav recordings back with the `mcap` library: channels, counts, metadata, the state stream."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from mcap.exceptions import McapError
from mcap.reader import make_reader

from fleet.recording.types import STATE_TOPIC
from sim.errors import ErrorCode, FleetError


def _open(path: str | Path) -> Any:
    p = Path(path)
    if not p.is_file():
        raise FleetError(ErrorCode.NOT_FOUND, f"no recording {p}", "give the recording.mcap of a run")
    return p.open("rb")


def channel_counts(path: str | Path) -> dict[str, tuple[str, int]]:
    """topic → (schema name, message count), from the file's summary section."""
    with _open(path) as f:
        try:
            s = make_reader(f).get_summary()
        except McapError as exc:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{path}: not a valid MCAP file: {exc}") from exc
    if s is None or s.statistics is None:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{path}: the MCAP file has no summary (was it closed?)")
    counts = s.statistics.channel_message_counts
    return {c.topic: (s.schemas[c.schema_id].name if c.schema_id in s.schemas else "", counts.get(cid, 0))
            for cid, c in sorted(s.channels.items())}


def metadata(path: str | Path) -> dict[str, dict[str, str]]:
    with _open(path) as f:
        return {m.name: dict(m.metadata) for m in make_reader(f).iter_metadata()}


def states(path: str | Path) -> Iterator[dict[str, Any]]:
    """The /fleetnav/state messages in log-time order."""
    with _open(path) as f:
        for _, _, msg in make_reader(f).iter_messages(topics=[STATE_TOPIC], log_time_order=True):
            yield json.loads(msg.data)
