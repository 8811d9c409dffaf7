"""Robot registry: what the fleet knows about each robot beyond its physics (namespace, model, home, health)."""

from __future__ import annotations

from dataclasses import dataclass, field

from sim.errors import ErrorCode, unknown_name
from sim.types import Pose2D


@dataclass
class RobotRecord:
    name: str
    model: str
    namespace: str
    home: Pose2D
    fidelity: str
    spawned_at: float
    health: dict[str, str] = field(default_factory=dict)  # sensor → ok | dropout | degraded
    killed: bool = False


class RobotRegistry:
    def __init__(self) -> None:
        self._robots: dict[str, RobotRecord] = {}

    def add(self, rec: RobotRecord) -> None:
        self._robots[rec.name] = rec

    def remove(self, name: str) -> RobotRecord:
        return self._robots.pop(self.get(name).name)

    def has(self, name: str) -> bool:
        return name in self._robots

    def get(self, name: str) -> RobotRecord:
        if name not in self._robots:
            raise unknown_name("robot", name, list(self._robots), ErrorCode.UNKNOWN_ROBOT)
        return self._robots[name]

    def names(self) -> list[str]:
        return list(self._robots)

    def records(self) -> list[RobotRecord]:
        return list(self._robots.values())
