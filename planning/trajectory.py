"""From a geometric path to a timed trajectory: shortcut, corner rounding, time parameterisation.

Smoothing never trusts itself: every shortcut and every rounded corner is checked against the costmap
(exact cell traversal), and a corner whose arc would clip a blocked cell keeps a smaller arc or stays
sharp. The time parameterisation is the classic forward/backward pass (a trapezoidal speed profile
along the path) under a curvature speed limit min(v_max, w_max/|κ|, sqrt(a_lat/|κ|)); a corner too
sharp to drive through becomes a stop and a turn in place with a trapezoidal angular-speed profile.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from planning.types import Costmap, Trajectory
from sim.errors import ErrorCode, FleetError
from sim.transforms import wrap_angle


def shortcut(path: np.ndarray, costmap: Costmap) -> np.ndarray:
    """Greedy string pulling: from each kept point jump to the farthest point still in straight view."""
    pts = np.asarray(path, dtype=float)
    out, i = [pts[0]], 0
    while i < len(pts) - 1:
        j = len(pts) - 1
        while j > i + 1 and not costmap.segment_free(tuple(pts[i]), tuple(pts[j])):
            j -= 1
        out.append(pts[j])
        i = j
    return np.asarray(out)


def round_corners(path: np.ndarray, costmap: Costmap, *, max_radius: float = 0.5, min_radius: float = 0.02,
                  step: float = 0.05) -> np.ndarray:
    """Replace each corner by a tangent circular arc (at most half of each adjacent segment), shrinking
    the radius until the arc is collision-free; a corner with no free arc ≥ min_radius stays sharp."""
    pts = np.asarray(path, dtype=float)
    out = [pts[0]]
    for i in range(1, len(pts) - 1):
        a, v, c = out[-1], pts[i], pts[i + 1]
        arc = _free_arc(a, v, c, costmap, max_radius, min_radius, step, last=i == len(pts) - 2)
        out.extend(arc if arc is not None else [v])
    out.append(pts[-1])
    return np.asarray(out)


def _free_arc(a: np.ndarray, v: np.ndarray, c: np.ndarray, costmap: Costmap, r_max: float, r_min: float,
              step: float, last: bool) -> list[np.ndarray] | None:
    l1, l2 = float(np.hypot(*(v - a))), float(np.hypot(*(c - v)))
    if l1 < 1e-9 or l2 < 1e-9:
        return None
    u1, u2 = (v - a) / l1, (c - v) / l2
    turn = math.atan2(u1[0] * u2[1] - u1[1] * u2[0], float(u1 @ u2))
    if abs(turn) < 1e-6:
        return None
    tan_half = math.tan(abs(turn) / 2)
    # The previous corner may already have used part of segment a→v; keep half of the next one free.
    r = min(r_max, l1 / tan_half, (l2 if last else 0.5 * l2) / tan_half)
    while r >= r_min:
        d = r * tan_half
        t1 = v - u1 * d
        normal = np.array([-u1[1], u1[0]]) * math.copysign(1.0, turn)
        centre = t1 + normal * r
        n = max(math.ceil(abs(turn) * r / step), 2)
        ang0 = math.atan2(t1[1] - centre[1], t1[0] - centre[0])
        angs = ang0 + np.linspace(0.0, turn, n + 1)
        arc = centre + r * np.column_stack([np.cos(angs), np.sin(angs)])
        pieces = [a, *arc]
        if all(costmap.segment_free(tuple(p), tuple(q)) for p, q in itertools.pairwise(pieces)) \
                and costmap.segment_free(tuple(arc[-1]), tuple(c)):
            return list(arc)
        r *= 0.5
    return None


def smooth_path(path: np.ndarray, costmap: Costmap, *, max_radius: float = 0.5, step: float = 0.05) -> np.ndarray:
    """Shortcut, then round the remaining corners; the result is collision-free on `costmap`."""
    return round_corners(shortcut(path, costmap), costmap, max_radius=max_radius, step=step)


def time_parameterize(path: np.ndarray, *, max_v: float, max_a: float, max_w: float = math.inf,
                      max_alpha: float = math.inf, max_lat_acc: float = math.inf, ds: float = 0.05,
                      pivot_angle: float = 0.35, start_yaw: float | None = None,
                      goal_yaw: float | None = None) -> Trajectory:
    """Timed samples (t, x, y, yaw, v, w) from rest to rest along `path` within the given limits.

    A turn sharper than `pivot_angle` between two samples is a stop-and-rotate; so are the initial turn
    from `start_yaw` and the final turn to `goal_yaw` when given.
    """
    for nm, val in (("max_v", max_v), ("max_a", max_a), ("max_w", max_w), ("max_alpha", max_alpha), ("ds", ds)):
        if not val > 0:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{nm} must be > 0, got {val}", "pass positive limits")
    pts = _resample(np.asarray(path, dtype=float), ds)
    if len(pts) < 2:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, "path needs two distinct points", "plan a path first")
    seg = np.diff(pts, axis=0)
    length = np.hypot(seg[:, 0], seg[:, 1])
    psi = np.arctan2(seg[:, 1], seg[:, 0])
    turn = np.zeros(len(pts))
    turn[1:-1] = np.array([wrap_angle(float(x)) for x in np.diff(psi)])
    pivot = np.abs(turn) > pivot_angle
    kappa = np.zeros(len(pts))
    kappa[1:-1] = np.where(pivot[1:-1], 0.0, turn[1:-1] / (0.5 * (length[:-1] + length[1:])))
    with np.errstate(divide="ignore"):
        vlim = np.minimum.reduce([np.full(len(pts), max_v), max_w / np.abs(kappa),
                                  np.sqrt(max_lat_acc / np.abs(kappa))])
    vlim[pivot] = 0.0
    vlim[0] = vlim[-1] = 0.0
    v = vlim.copy()
    for i in range(len(pts) - 1):  # forward: accelerate no faster than max_a
        v[i + 1] = min(v[i + 1], math.sqrt(v[i] ** 2 + 2 * max_a * length[i]))
    for i in range(len(pts) - 2, -1, -1):  # backward: brake no harder than max_a
        v[i] = min(v[i], math.sqrt(v[i + 1] ** 2 + 2 * max_a * length[i]))
    rows: list[tuple[float, float, float, float, float, float]] = []
    t = 0.0
    heading = psi[0] if start_yaw is None else start_yaw
    t = _rotate(rows, t, pts[0], heading, float(psi[0]), max_w, max_alpha)
    for i in range(len(pts) - 1):
        yaw = float(psi[i])
        if pivot[i]:
            t = _rotate(rows, t, pts[i], float(psi[i - 1]), yaw, max_w, max_alpha)
        rows.append((t, pts[i][0], pts[i][1], yaw, v[i], v[i] * kappa[i]))
        vm = v[i] + v[i + 1]
        if vm <= 0.0:  # both ends at rest (two pivots in a row): a short trapezoid of its own
            t = _rest_to_rest(rows, t, pts[i], seg[i], float(length[i]), yaw, max_v, max_a)
        else:
            t += 2.0 * length[i] / vm
    end_yaw = float(psi[-1])
    rows.append((t, pts[-1][0], pts[-1][1], end_yaw, 0.0, 0.0))
    if goal_yaw is not None:
        _rotate(rows, t, pts[-1], end_yaw, goal_yaw, max_w, max_alpha)
    # A turn in place ends in the state the next sample starts from: keep one row per instant.
    rows = [r for k, r in enumerate(rows) if k + 1 == len(rows) or rows[k + 1][0] > r[0]]
    arr = np.asarray(rows, dtype=float)
    return Trajectory(t=arr[:, 0], x=arr[:, 1], y=arr[:, 2], yaw=arr[:, 3], v=arr[:, 4], w=arr[:, 5],
                      max_v=max_v, max_a=max_a)


def _rotate(rows: list[tuple[float, float, float, float, float, float]], t: float, p: np.ndarray,
            yaw0: float, yaw1: float, max_w: float, max_alpha: float) -> float:
    """Append an in-place turn yaw0 → yaw1 (shortest way), trapezoidal in w; returns the end time."""
    d = wrap_angle(yaw1 - yaw0)
    if abs(d) < 1e-9:
        return t
    if math.isinf(max_w) or math.isinf(max_alpha):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, "a turn in place needs finite max_w and max_alpha",
                         "pass the robot's angular limits")
    sgn, ang = math.copysign(1.0, d), abs(d)
    w_peak = min(max_w, math.sqrt(ang * max_alpha))  # triangular when the turn is too short to cruise
    t_acc = w_peak / max_alpha
    t_cruise = (ang - w_peak * t_acc) / w_peak
    rows.append((t, p[0], p[1], yaw0, 0.0, 0.0))
    rows.append((t + t_acc, p[0], p[1], wrap_angle(yaw0 + sgn * 0.5 * w_peak * t_acc), 0.0, sgn * w_peak))
    if t_cruise > 1e-12:
        rows.append((t + t_acc + t_cruise, p[0], p[1], wrap_angle(yaw1 - sgn * 0.5 * w_peak * t_acc), 0.0,
                     sgn * w_peak))
    end = t + 2 * t_acc + t_cruise
    rows.append((end, p[0], p[1], wrap_angle(yaw1), 0.0, 0.0))
    return end


def _rest_to_rest(rows: list[tuple[float, float, float, float, float, float]], t: float, a: np.ndarray,
                  d: np.ndarray, length: float, yaw: float, max_v: float, max_a: float) -> float:
    """Samples strictly inside a rest-to-rest straight move of `length` along d; returns the arrival time."""
    v_peak = min(max_v, math.sqrt(max_a * length))
    t_acc = v_peak / max_a
    cruise = length - v_peak * t_acc
    for frac, dt in ((0.5 * v_peak * t_acc / length, t_acc), (1.0 - 0.5 * v_peak * t_acc / length, cruise / v_peak)):
        t += dt
        p = a + frac * d
        rows.append((t, p[0], p[1], yaw, v_peak, 0.0))
    return t + t_acc


def _resample(pts: np.ndarray, ds: float) -> np.ndarray:
    """Keep every vertex, add points so no segment is longer than ds; drop repeated points."""
    out = [pts[0]]
    for a, b in itertools.pairwise(pts):
        n = math.ceil(float(np.hypot(*(b - a))) / ds)
        if n == 0:
            continue
        out.extend(a + (b - a) * (k / n) for k in range(1, n + 1))
    return np.asarray(out)
