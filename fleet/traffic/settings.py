"""The traffic layer's settings that are not free numbers, checked before anything is built (one clear error
per bad value, naming the setting and what it may be)."""

from __future__ import annotations

import math

from fleet.traffic.admission import ADMISSION
from sim.errors import ErrorCode, FleetError, unknown_name

PRIORITIES = ("goal_age", "since_progress")  # PIBT priority: time since the goal was given / since it last got closer
URGENT_RANKS = ("since_progress", "since_urgent")  # order among urgent robots (priority.priorities)
WITHDRAW = ("off", "loops", "ahead", "both", "flush", "crowded")  # unstarted moves withdrawn (withdraw.py)


def check_settings(*, cell: float, gap: float, radius: float, priority: str, window: int, urgent_s: float | None,
                   urgent_rank: str, highway: float, congestion: float, withdraw: str, flush_s: float,
                   admission: str, urgent_cells: int | None = None, urgent_window: int = 1,
                   keep_clear_s: float = 4.0, hold_ground_s: float | None = None) -> None:
    """Raise INVALID_ARGUMENT for the first setting out of its range (`gap`: the cell a robot needs, m)."""
    if gap > cell:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"traffic cell {cell} m is too small for a robot of "
                         f"radius {radius:.3f} m", f"use cell ≥ {gap:.2f} m")
    if priority not in PRIORITIES:
        raise unknown_name("traffic priority", priority, list(PRIORITIES), ErrorCode.INVALID_ARGUMENT)
    for key, value in (("window", window), ("urgent_window", urgent_window)):
        if value < 1:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"traffic {key} must be ≥ 1 step, got {value}")
    if urgent_s is not None and not (math.isfinite(urgent_s) and urgent_s > 0):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"traffic urgent_s must be > 0 s (or None: off), got "
                         f"{urgent_s}")
    if urgent_rank not in URGENT_RANKS:
        raise unknown_name("traffic urgent_rank", urgent_rank, list(URGENT_RANKS), ErrorCode.INVALID_ARGUMENT)
    if not (math.isfinite(highway) and highway >= 1.0):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"traffic highway must be ≥ 1 (1: no lanes), got {highway}")
    if not (math.isfinite(congestion) and congestion >= 0.0):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"traffic congestion must be ≥ 0 (0: off), got {congestion}")
    if withdraw not in WITHDRAW:
        raise unknown_name("traffic withdraw", withdraw, list(WITHDRAW), ErrorCode.INVALID_ARGUMENT)
    if not (math.isfinite(flush_s) and flush_s > 0):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"traffic flush_s must be > 0 s, got {flush_s}")
    if admission not in ADMISSION:
        raise unknown_name("traffic admission", admission, list(ADMISSION), ErrorCode.INVALID_ARGUMENT)
    if not (math.isfinite(keep_clear_s) and keep_clear_s > 0):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"traffic keep_clear_s must be > 0 s (a robot kept out of a "
                         f"crossing that long at rest enters anyway), got {keep_clear_s}")
    if hold_ground_s is not None and not (math.isfinite(hold_ground_s) and hold_ground_s >= 0):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"traffic hold_ground_s must be ≥ 0 s (or None: off), got "
                         f"{hold_ground_s}")
    if urgent_cells is not None and urgent_cells < 1:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"traffic urgent_cells must be ≥ 1 cell (or None: urgent until "
                         f"the goal), got {urgent_cells}")
