"""The path a controller tracks: a densely resampled polyline with heading, curvature and a speed profile.

Controllers follow the path by arc length, not by the clock: a robot slowed by the reactive layer resumes
where it is instead of chasing a reference that ran away. Projection searches a window around the last
progress so self-crossing paths (a figure-eight) never make the robot jump to the other branch.
"""

from __future__ import annotations

import math

import numpy as np

from planning.types import Trajectory
from sim.errors import ErrorCode, FleetError


class PathReference:
    """Arc-length parameterised reference; all arrays have one entry per sample, `ds` apart."""

    def __init__(self, *, xy: np.ndarray, speed: np.ndarray, ds: float = 0.02) -> None:
        xy = np.asarray(xy, dtype=float)
        speed = np.broadcast_to(np.asarray(speed, dtype=float), (xy.shape[0],)) if xy.ndim == 2 else speed
        if xy.ndim != 2 or xy.shape[1] != 2 or xy.shape[0] < 2 or not np.all(np.isfinite(xy)):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, "a reference path needs >= 2 finite (x, y) points",
                             "pass an (N, 2) array")
        keep = np.r_[True, np.hypot(*np.diff(xy, axis=0).T) > 1e-9]  # drop repeated points
        xy, speed = xy[keep], speed[keep]
        if xy.shape[0] < 2:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, "the reference path has zero length",
                             "start and goal coincide: nothing to track")
        s_in = np.r_[0.0, np.cumsum(np.hypot(*np.diff(xy, axis=0).T))]
        self.length = float(s_in[-1])
        n = max(2, math.ceil(self.length / ds) + 1)
        self.s = np.linspace(0.0, self.length, n)
        self.ds = self.length / (n - 1)
        self.x = np.interp(self.s, s_in, xy[:, 0])
        self.y = np.interp(self.s, s_in, xy[:, 1])
        self.v = np.interp(self.s, s_in, speed)
        # Heading from central differences (smooths polyline corners over one sample), unwrapped.
        self.yaw = np.unwrap(np.arctan2(np.gradient(self.y), np.gradient(self.x)))
        self.kappa = np.gradient(self.yaw, self.ds)

    # ---- construction -------------------------------------------------------------------------------

    @staticmethod
    def from_points(xy: np.ndarray, *, max_v: float, max_a: float, max_lat_a: float = 0.5,
                    ds: float = 0.02, stop_at_end: bool = True) -> PathReference:
        """A speed profile for a bare path: v ≤ max_v, v²·|κ| ≤ max_lat_a, and braking to 0 at the end."""
        ref = PathReference(xy=xy, speed=np.full(len(xy), max_v), ds=ds)
        ref.v = speed_profile(ref.s, ref.kappa, max_v=max_v, max_a=max_a, max_lat_a=max_lat_a,
                              stop_at_end=stop_at_end)
        return ref

    @staticmethod
    def from_trajectory(traj: Trajectory, ds: float = 0.02) -> PathReference:
        """Keep the trajectory's geometry and its time parameterisation's speed, as a function of s."""
        return PathReference(xy=traj.xy(), speed=np.abs(traj.v), ds=ds)

    # ---- queries ------------------------------------------------------------------------------------

    def index(self, s: float) -> int:
        return int(min(max(round(s / self.ds), 0), self.s.size - 1))

    def project(self, x: float, y: float, s_hint: float | None = None, window: float = 2.0) -> tuple[float, float]:
        """(s, signed cross-track) of the nearest sample, searched within [s_hint - 0.5, s_hint + window]."""
        if s_hint is None:
            lo, hi = 0, self.s.size
        else:
            lo = self.index(s_hint - 0.5)
            hi = self.index(s_hint + window) + 1
        d2 = (self.x[lo:hi] - x) ** 2 + (self.y[lo:hi] - y) ** 2
        i = lo + int(np.argmin(d2))
        c, s_ = math.cos(self.yaw[i]), math.sin(self.yaw[i])
        along = (x - self.x[i]) * c + (y - self.y[i]) * s_
        lateral = -(x - self.x[i]) * s_ + (y - self.y[i]) * c
        s_proj = min(max(self.s[i] + along, 0.0), self.length)
        return float(s_proj), float(lateral)

    def at(self, s: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(x, y, yaw, v, kappa) at arc length(s), linearly interpolated, clamped to the ends."""
        s = np.clip(np.asarray(s, dtype=float), 0.0, self.length)
        return (np.interp(s, self.s, self.x), np.interp(s, self.s, self.y), np.interp(s, self.s, self.yaw),
                np.interp(s, self.s, self.v), np.interp(s, self.s, self.kappa))

    def horizon(self, s0: float, n: int, dt: float, yaw_near: float,
                min_v: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
        """Reference states (n+1, 3) and inputs (n, 2) for an MPC, stepping s by the profile's speed.

        The speed used to advance s is floored at `min_v` until the end so the horizon never stalls at a
        standstill reference (e.g. at the start of a path); at the end the reference holds still.
        """
        s = np.empty(n + 1)
        s[0] = s0
        for k in range(n):
            v_k = float(np.interp(s[k], self.s, self.v))
            s[k + 1] = min(self.length, s[k] + max(v_k, min_v if s[k] < self.length else 0.0) * dt)
        x, y, yaw, _, kappa = self.at(s)
        yaw = yaw + 2 * math.pi * round((yaw_near - yaw[0]) / (2 * math.pi))  # same branch as the robot
        v_ref = np.diff(s) / dt
        states = np.column_stack([x, y, yaw])
        inputs = np.column_stack([v_ref, v_ref * kappa[:-1]])
        return states, inputs

    def remaining(self, s: float) -> float:
        return max(0.0, self.length - s)

    def xy(self) -> np.ndarray:
        return np.column_stack([self.x, self.y])


def speed_profile(s: np.ndarray, kappa: np.ndarray, *, max_v: float, max_a: float, max_lat_a: float,
                  stop_at_end: bool = True) -> np.ndarray:
    """Forward-backward pass: curvature-limited speed, then acceleration-limited ramps (0 at the end)."""
    # Curvature from a polyline is spiky at corners; a short moving maximum keeps the slow-down around it.
    k = np.abs(kappa)
    width = max(1, int(0.15 / max(s[1] - s[0], 1e-9)))
    k = np.max(np.lib.stride_tricks.sliding_window_view(np.pad(k, width, mode="edge"), 2 * width + 1), axis=1)
    v = np.minimum(max_v, np.sqrt(max_lat_a / np.maximum(k, 1e-9)))
    if stop_at_end:
        v[-1] = 0.0
    ds = np.diff(s)
    for i in range(v.size - 2, -1, -1):  # braking: v_i² ≤ v_{i+1}² + 2 a ds
        v[i] = min(v[i], math.sqrt(v[i + 1] ** 2 + 2 * max_a * ds[i]))
    return v
