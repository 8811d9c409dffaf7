"""Rubric items: each check says pass/fail, what was measured, what was expected, and the points."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class RubricItem:
    key: str
    description: str
    points: float
    passed: bool
    measured: str
    expected: str

    @property
    def earned(self) -> float:
        return self.points if self.passed else 0.0

    def to_dict(self) -> dict[str, Any]:
        return {"key": self.key, "description": self.description, "points": self.points, "earned": self.earned,
                "passed": self.passed, "measured": self.measured, "expected": self.expected}


@dataclass
class RubricReport:
    title: str
    source: str
    items: list[RubricItem] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def add(self, key: str, description: str, points: float, passed: bool, measured: str, expected: str) -> None:
        self.items.append(RubricItem(key, description, points, bool(passed), measured, expected))

    @property
    def earned(self) -> float:
        return sum(i.earned for i in self.items)

    @property
    def total(self) -> float:
        return sum(i.points for i in self.items)

    @property
    def passed(self) -> bool:
        return all(i.passed for i in self.items)

    def failed_keys(self) -> list[str]:
        return [i.key for i in self.items if not i.passed]

    def to_dict(self) -> dict[str, Any]:
        return {"title": self.title, "source": self.source, "earned": self.earned, "total": self.total,
                "passed": self.passed, "items": [i.to_dict() for i in self.items], "notes": self.notes}
