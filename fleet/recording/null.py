"""NullRecorder: stands in for a recorder when recording is off, so the runner never asks `if recording`."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from fleet.service import FleetService


class NullRecorder:
    def attach(self, svc: FleetService, mission_yaml: str, seed: int) -> None:
        """Records nothing."""

    def close(self) -> dict[str, int]:
        return {}
