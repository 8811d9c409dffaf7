"""Clock modes: paused, step N, real time × speed, as fast as possible. Time is always sim time; the clock
only decides how fast wall time lets it advance."""

from __future__ import annotations

import math
import time
from enum import StrEnum
from typing import TYPE_CHECKING

from sim.errors import ErrorCode, FleetError

if TYPE_CHECKING:
    from sim.world import World


class ClockMode(StrEnum):
    PAUSED = "paused"
    REALTIME = "realtime"  # sim time advances at `speed` × wall time
    FAST = "fast"  # as fast as possible


class Clock:
    """Paces a world. `advance(world, wall_budget)` steps it as the mode allows within a wall-time budget."""

    def __init__(self, mode: ClockMode = ClockMode.PAUSED, speed: float = 1.0) -> None:
        self.mode = mode
        self.speed = speed
        self._anchor_wall = time.perf_counter()
        self._anchor_sim = 0.0

    def set_mode(self, mode: ClockMode | str, world: World, speed: float | None = None) -> None:
        try:
            mode = ClockMode(mode)
        except ValueError as exc:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"unknown clock mode '{mode}'",
                             f"use one of {[m.value for m in ClockMode]}") from exc
        if speed is not None:
            if not (math.isfinite(speed) and 0 < speed <= 1000):
                raise FleetError(ErrorCode.INVALID_ARGUMENT, f"speed must be in (0, 1000], got {speed}")
            self.speed = speed
        self.mode = mode
        self._anchor_wall, self._anchor_sim = time.perf_counter(), world.time

    def steps_due(self, world: World, max_steps: int = 1000) -> int:
        """How many steps to take now: all the sim time owed at `speed` in REALTIME, `max_steps` in FAST."""
        if self.mode is ClockMode.PAUSED:
            return 0
        if self.mode is ClockMode.FAST:
            return max_steps
        target = self._anchor_sim + (time.perf_counter() - self._anchor_wall) * self.speed
        owed = int((target - world.time) / world.dt)
        return max(0, min(owed, max_steps))

    def seconds_until_next_step(self, world: World) -> float:
        if self.mode is not ClockMode.REALTIME:
            return 0.0
        target_wall = self._anchor_wall + (world.time + world.dt - self._anchor_sim) / self.speed
        return max(0.0, target_wall - time.perf_counter())

    def real_time_factor(self, sim_elapsed: float, wall_elapsed: float) -> float:
        return sim_elapsed / wall_elapsed if wall_elapsed > 0 else math.inf
