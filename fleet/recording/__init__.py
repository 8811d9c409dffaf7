"""fleet.recording: MCAP recordings with Foxglove schemas, the null recorder, replay and run diffs."""

from fleet.recording.diff import diff_runs
from fleet.recording.mcap_recorder import McapRecorder
from fleet.recording.null import NullRecorder
from fleet.recording.publisher import FoxglovePublisher
from fleet.recording.reader import channel_counts, metadata, states
from fleet.recording.replay import replay
from fleet.recording.types import STATE_TOPIC, DiffResult, Recorder, ReplayResult

__all__ = [
    "STATE_TOPIC",
    "DiffResult",
    "FoxglovePublisher",
    "McapRecorder",
    "NullRecorder",
    "Recorder",
    "ReplayResult",
    "channel_counts",
    "diff_runs",
    "metadata",
    "replay",
    "states",
]
