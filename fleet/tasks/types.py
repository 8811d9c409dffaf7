"""Types shared by task types and the allocator: what a task costs a robot, independent of which robot."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

XY = tuple[float, float]


@dataclass(frozen=True, slots=True)
class WorkProfile:
    """The robot-independent part of a task, for allocation: the robot drives from wherever it is to `start`,
    then does `length` metres of work (plus `duration` seconds standing: dwells) and ends at `end`."""

    start: XY
    end: XY
    length: float = 0.0  # m driven doing the work itself, after reaching `start`
    duration: float = 0.0  # s spent not driving (dwell times)
    path: np.ndarray | None = None  # (N, 2) polyline of the work itself (waypoints, a coverage path)
