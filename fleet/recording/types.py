"""Interfaces and result types of fleet.recording: the Recorder protocol, replay and diff results."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    from fleet.service import FleetService

STATE_TOPIC = "/fleetnav/state"
MISSION_METADATA = "fleetnav.mission"  # MCAP metadata record: the mission YAML actually run, and its seed
SPAWN_METADATA = "fleetnav.spawn"  # MCAP metadata record: each robot's spawn pose, model and fidelity
STATE_SCHEMA: dict[str, Any] = {
    "type": "object",
    "title": "fleetnav.State",
    "description": "Fleet state after a control tick: rows in `names` order; cmd is the command in force.",
    "properties": {
        "t": {"type": "number"}, "names": {"type": "array", "items": {"type": "string"}},
        "pose": {"type": "array", "items": {"type": "array", "items": {"type": "number"}}},
        "twist": {"type": "array", "items": {"type": "array", "items": {"type": "number"}}},
        "cmd": {"type": "array", "items": {"type": "array", "items": {"type": "number"}}},
        "estopped": {"type": "array", "items": {"type": "boolean"}},
        "in_collision": {"type": "array", "items": {"type": "boolean"}},
    },
}


class Recorder(Protocol):
    """What the mission runner drives: attach to a service before it steps, close at the end."""

    def attach(self, svc: FleetService, mission_yaml: str, seed: int) -> object: ...

    def close(self) -> dict[str, int]:
        """Finish; returns the message count per topic."""
        ...


@dataclass
class ReplayResult:
    """A world re-driven by a recording's commands, compared with the recorded poses."""

    source: str
    ticks: int
    end_time: float
    robots: list[str]
    max_divergence_m: dict[str, float] = field(default_factory=dict)
    final_divergence_m: dict[str, float] = field(default_factory=dict)
    output: str | None = None

    @property
    def max_m(self) -> float:
        return max(self.max_divergence_m.values(), default=0.0)

    def to_dict(self) -> dict[str, Any]:
        return {"source": self.source, "ticks": self.ticks, "end_time": self.end_time, "robots": self.robots,
                "max_divergence_m": self.max_divergence_m, "final_divergence_m": self.final_divergence_m,
                "output": self.output}


@dataclass
class DiffResult:
    """Differences between two runs: assertions that changed verdict, metrics and trajectories that moved."""

    a: str
    b: str
    verdicts: list[dict[str, Any]] = field(default_factory=list)
    metrics: list[dict[str, Any]] = field(default_factory=list)
    trajectories: dict[str, float] = field(default_factory=dict)  # robot → max position difference, m
    only_in: dict[str, list[str]] = field(default_factory=dict)

    @property
    def identical(self) -> bool:
        return not (self.verdicts or self.metrics or any(v > 0 for v in self.trajectories.values())
                    or any(self.only_in.values()))
