"""What a `LogSlam` run reports besides its poses: the front end's counters and timings, and the occupancy map
built from the scans at the final poses."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from planning.grid import OccupancyGrid
from slam import se2
from slam.factories import make_mapper
from slam.log_config import LogSlamConfig


@dataclass
class FrontEndStats:
    matched: int = 0  # edges from the normal window
    wide: int = 0  # edges that needed the wide window
    odometry_only: int = 0  # no match: the odometry (or no motion) with a loose σ
    ambiguous: int = 0  # wide matches whose score surface has a second peak (edge σ from the surface)
    lookahead: int = 0  # wide matches with near-tied distinct peaks, decided by the next scans
    lookahead_switched: int = 0  # … where an alternative peak won
    local_map_builds: int = 0
    times: list[float] = field(default_factory=list)  # s of wall time per scan
    cpu_times: list[float] = field(default_factory=list)  # s of process CPU time per scan (all threads)
    finish_cpu: float = 0.0  # s of process CPU time in finish() (end-of-log optimisation, `slam.densify`)


def scan_map(poses: np.ndarray, points: Sequence[np.ndarray], cfg: LogSlamConfig) -> OccupancyGrid:
    """Occupancy grid from every scan (base-frame `points`) that moved enough since the last integrated one."""
    mapper = make_mapper(cfg.mapping.model_copy(update={"clear_no_return": False}))  # a log's no-returns clear nothing
    last: np.ndarray | None = None
    for k in range(len(poses)):
        if last is not None:
            d = se2.between_many(last[None], poses[k][None])[0]
            if math.hypot(d[0], d[1]) + abs(d[2]) / 10 < cfg.map_every_distance:
                continue
        p = poses[k]
        mapper.integrate((float(p[0]), float(p[1]), float(p[2])), points[k])
        last = p
    return mapper.grid()
