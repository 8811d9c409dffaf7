"""Interlaced-scan deskewing, with the interlace delay estimated from the scans themselves.

A SICK LMS at 0.5° (or 0.25°) resolution builds one scan from two (four) sweeps of its mirror, 13.3 ms apart
at 75 Hz: the even beams come from one sweep and the odd beams from the next. While the robot turns, the two
halves are rotated against each other by ω·T (measured on freiburg-079: odd vs even beams 0.48° apart at
ω > 0.4 rad/s, T ≈ 14 ms), so every wall is seen twice, 4 cm apart at 5 m. The scan matcher then fits the
blur, and the local map is built from blurred scans.

Nothing in a CARMEN FLASER line says whether the scan is interlaced, nor which half comes first. So the delay
is estimated online: on scans taken while turning, the odd beams are matched to the even beams (point-to-line
ICP) and their relative heading regressed on the turn rate, yaw = T·ω + c (c absorbs any constant offset
between the halves, e.g. a beam layout half a step off). Once that fit is significant, every scan's odd beams
and even beams are moved into the frame of the sensor midway between the two sweeps by the motion over ±T/2
(a constant velocity). Midway, so that the scan's pose keeps the time a blurred scan's match stood for (and
a reference made from blurred scans): moving only the odd half measured worse on freiburg-079 (0.0789 against
0.0736 m). A scan from a single sweep (a 1° SICK, any scanner that is not interlaced) gives T ≈ 0 and is left
as it is. The turn rate is the odometry's at the scan's stamp where the log's ODOM lines are finer than its
scans, else the odometry step between scans, else the last estimated step.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import Field

from sim.config import StrictModel
from sim.transforms import se2_between
from slam import se2
from slam.icp import IcpTarget, icp


class DeskewConfig(StrictModel):
    """`frontend.deskew`: interlaced-scan deskewing (`slam.deskew`)."""

    enabled: bool = Field(True, description="estimate the delay between a scan's even and odd beams online "
                          "and move both halves to the pose midway between the two sweeps (freiburg-079: ATE 0.0806 → "
                          "0.0736 m, seattle 0.0388 → 0.0369; no delay found on 1° scans; docs/benchmarks-slam.md, "
                          "helper 14y)")
    min_rate: float = Field(0.1, gt=0, description="scans turning at least this fast are used for the "
                            "estimate, rad/s")
    min_samples: int = Field(30, ge=5, description="… and the delay is used once this many agree")
    max_samples: int = Field(400, ge=5, description="… and no more are matched (CPU)")
    min_t_ratio: float = Field(4.0, gt=0, description="… significantly: |T| ≥ this × its standard error")
    max_delay: float = Field(0.05, gt=0, description="a fit beyond ± this is not an interlace, s")
    max_interval: float = Field(1.0, gt=0, description="a step's turn rate (the odometry step, else the last "
                                "estimated step, over the scans' interval) is not used over a longer interval: "
                                "it says nothing about the rate during the sweep (without a rate from the ODOM "
                                "lines the scan is then left as it is), s")
    odometry_rate: bool = Field(True, description="use the odometry's rate over the ODOM interval holding the "
                                "scan's stamp, where the log's ODOM lines are finer than its scans (≥ 3 since the "
                                "previous scan: a log of keyframes, scans seconds apart), instead of the step "
                                "between scans")
    max_range: float = Field(8.0, gt=0, description="returns used for the even/odd match, m")
    min_points: int = Field(60, ge=10, description="… at least this many per half")


class InterlaceDeskew:
    def __init__(self, config: DeskewConfig) -> None:
        self.config = config
        self._rows: list[tuple[float, float]] = []  # (ω rad/s, odd-vs-even yaw rad)
        self._delay: tuple[int, float] = (-1, 0.0)  # (samples it was fitted on, T)

    @property
    def samples(self) -> int:
        return len(self._rows)

    def delay(self) -> float:
        """T in s (0 until the fit is significant): the odd beams are taken T after the even ones."""
        if self._delay[0] != len(self._rows):
            self._delay = (len(self._rows), self._fit())
        return self._delay[1]

    def _fit(self) -> float:
        cfg = self.config
        if len(self._rows) < cfg.min_samples:
            return 0.0
        a = np.array(self._rows)
        x = np.column_stack([a[:, 0], np.ones(len(a))])
        coef, *_ = np.linalg.lstsq(x, a[:, 1], rcond=None)
        dof = max(len(a) - 2, 1)
        s2 = float(np.sum((a[:, 1] - x @ coef) ** 2)) / dof
        se = math.sqrt(s2 * float(np.linalg.inv(x.T @ x)[0, 0]))
        t = float(coef[0])
        if abs(t) > cfg.max_delay or abs(t) < cfg.min_t_ratio * se:
            return 0.0
        return t

    def observe(self, points: np.ndarray, ranges: np.ndarray, odd: np.ndarray, omega: float) -> None:
        """One scan (sensor-frame points, their ranges, which are odd beams) taken turning at ω rad/s."""
        cfg = self.config
        if abs(omega) < cfg.min_rate or len(self._rows) >= cfg.max_samples:
            return
        near = ranges <= cfg.max_range
        ev, od = points[near & ~odd], points[near & odd]
        if len(ev) < cfg.min_points or len(od) < cfg.min_points:
            return
        fit = icp(od, IcpTarget.from_points(ev), (0.0, 0.0, 0.0), max_correspondence=0.1, inlier_distance=0.1)
        if fit.converged and fit.inlier_ratio > 0.5:
            self._rows.append((omega, float(fit.pose[2])))

    def process(self, points: np.ndarray, ranges: np.ndarray, odd: np.ndarray, velocity: se2.PoseTuple
                ) -> np.ndarray:
        """`observe` the scan, then `apply` the delay learnt so far."""
        self.observe(points, ranges, odd, velocity[2])
        return self.apply(points, odd, velocity)

    def apply(self, points: np.ndarray, odd: np.ndarray, velocity: se2.PoseTuple) -> np.ndarray:
        """The odd beams' points moved forward, and the even beams' back, by the motion over half the delay
        (`velocity`: vx, vy in m/s and ω in rad/s, sensor frame), into the frame of the sensor midway between
        the two sweeps."""
        t = self.delay()
        if t == 0.0 or not odd.any():
            return points
        out = points.copy()
        h = 0.5 * t  # both halves to the middle of the two sweeps: the time a blurred scan's match stands for
        half = (velocity[0] * h, velocity[1] * h, velocity[2] * h)
        out[odd] = se2.transform_points(half, points[odd])
        # (the matrix inverse, not se2_inverse: the two differ in the last bit, and freiburg-079's ATE moves by
        # up to 5 mm with such a difference — the figures in docs/benchmarks-slam.md are with this one)
        out[~odd] = se2.transform_points(se2.from_matrix(np.linalg.inv(se2.to_matrix(half))), points[~odd])
        return out


def step_velocity(stamp: float, stamps: list[float], prev_odom: se2.PoseTuple | None, odom: se2.PoseTuple | None,
                  poses: list[se2.PoseTuple], max_interval: float) -> se2.PoseTuple | None:
    """(vx, vy, ω) in the sensor frame at a scan: its odometry step (`prev_odom` → `odom`), else the last
    estimated step (`poses`), over the stamps' interval; None without usable stamps or over a longer interval
    than `max_interval`."""
    dt = stamp - stamps[-1]
    if prev_odom is not None and odom is not None:
        step = se2_between(prev_odom, odom)
    elif len(poses) >= 2:
        step, dt = se2_between(poses[-2], poses[-1]), stamps[-1] - stamps[-2]
    else:
        return None
    if not 1e-3 < dt < max_interval:
        return None
    return (step[0] / dt, step[1] / dt, step[2] / dt)
