"""Footprint-exact dynamic-window controller over a navigation function.

Each tick it samples (v, ω) reachable within one control period under the acceleration limits, rolls each
out at constant twist over `horizon_s`, and checks the real rectangle (+ safety margin) against the obstacle
points at every rollout pose (poses far from everything are cleared by the distance field without the exact
test). A twist is admissible when it can still stop before its first contact (braking distance at the
braking deceleration). Among admissible twists it takes the one whose collision-free end has the lowest
cost-to-go (the NavField: the global route, inflation included), plus penalties for pointing away from the
route and for skimming obstacles. Reversing is allowed at low speed, so backing out of a dead end and
turning in place come out of the same search.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from planning.navfn import NavField
from planning.obstacle_map import ObstacleMap
from planning.rect_footprint import RectFootprint
from sim.config import StrictModel
from sim.types import Pose2D


class DwaConfig(StrictModel):
    horizon_s: float = 1.6
    dt: float = 0.05  # between checked poses; the check widens by half the footprint's sweep between them
    v_samples: int = 9
    w_samples: int = 15
    max_reverse: float = 0.3  # m/s
    brake_decel: float = 2.0  # m/s², assumed when checking a twist can stop before a contact
    heading_weight: float = 0.6  # m of cost-to-go per unit (1 − cos) of heading error to the route
    clearance_weight: float = 1.0  # m of cost-to-go per m below `clearance_soft`
    clearance_soft: float = 0.12  # m: closer than this (footprint to obstacle) costs extra
    spin_weight: float = 0.05  # m per rad/s: prefer straight among equals
    reverse_weight: float = 0.5  # m per m/s of reversing


@dataclass(frozen=True, slots=True)
class DwaChoice:
    v: float
    w: float
    admissible: int  # how many sampled twists were admissible
    score: float
    clearance: float  # min footprint distance along the chosen rollout, m


class FootprintDwa:
    def __init__(self, cfg: DwaConfig, *, footprint: RectFootprint, margin: float, max_v: float, max_w: float,
                 max_a: float, max_alpha: float, control_dt: float) -> None:
        self.cfg, self.fp, self.margin = cfg, footprint, margin
        self.max_v, self.max_w, self.max_a, self.max_alpha, self.control_dt = max_v, max_w, max_a, max_alpha, control_dt
        n = round(cfg.horizon_s / cfg.dt)
        self.t = cfg.dt * np.arange(1, n + 1)

    def choose(self, pose: Pose2D, twist: tuple[float, float], field: NavField, omap: ObstacleMap) -> DwaChoice:
        cfg = self.cfg
        v0, w0 = twist
        dv, dw = self.max_a * self.control_dt, self.max_alpha * self.control_dt
        vs = np.unique(np.clip(np.linspace(v0 - dv, v0 + dv, cfg.v_samples), -cfg.max_reverse, self.max_v))
        vs = np.unique(np.r_[vs, 0.0] if vs.min() <= 0.0 <= vs.max() else vs)
        ws = np.unique(np.clip(np.r_[np.linspace(w0 - dw, w0 + dw, cfg.w_samples), 0.0 if abs(w0) <= dw else w0],
                               -self.max_w, self.max_w))
        V, W = (a.ravel() for a in np.meshgrid(vs, ws))
        poses = _rollouts(pose, V, W, self.t)  # (K, T, 3)
        K, T = V.size, self.t.size
        flat = poses.reshape(-1, 3)
        clear = self._clearance(flat, omap).reshape(K, T)
        # a point obstacle missed between two checked poses is within half the sweep of one of them
        sweep = 0.5 * (np.abs(V) + np.abs(W) * self.fp.circumscribed) * cfg.dt
        thr = self.margin + sweep
        # already inside the margin (pushed there by what the lidar saw late): any motion that gets no closer
        # than now (and never closer than 1 cm) is allowed, so the robot can always back or turn out
        here = float(self._clearance(np.array([[pose.x, pose.y, pose.yaw]]), omap)[0])
        thr = np.where(here < thr, max(here - 1e-3, 0.01), thr)
        hit = clear < thr[:, None]
        first = np.where(hit.any(axis=1), hit.argmax(axis=1), T)  # index of the first colliding pose
        travel = np.abs(V) * self.t[np.minimum(first, T - 1)] * (first < T) + np.abs(V) * self.t[-1] * (first == T)
        free_len = np.where(first < T, np.abs(V) * np.where(first > 0, self.t[np.maximum(first - 1, 0)], 0.0), travel)
        stop = V**2 / (2 * cfg.brake_decel) + np.abs(V) * self.control_dt + 0.02
        admissible = (first == T) | ((first > 0) & (free_len >= stop))
        # a twist whose very first pose already collides is never admissible (unless it is a pure rotation
        # out of an overlap: handled by the caller's recovery)
        # each rollout is judged at its best collision-free pose (lowest cost-to-go): one that passes the
        # goal is not blamed for overshooting it within the horizon
        along = field.value(flat[:, :2]).reshape(K, T)
        along = np.where(np.arange(T)[None, :] < np.maximum(first, 1)[:, None], along, np.inf)
        best = np.argmin(along, axis=1)
        end = poses[np.arange(K), best]
        ctg = along[np.arange(K), best]
        # heading: the downhill direction of the field at the end pose
        g = _gradient(field, end[:, :2], omap.resolution)
        head = np.where(np.hypot(g[:, 0], g[:, 1]) > 1e-9,
                        1.0 - np.cos(end[:, 2] - np.arctan2(-g[:, 1], -g[:, 0])), 0.0)
        minclear = np.min(np.where(np.arange(T)[None, :] < np.maximum(first, 1)[:, None], clear, np.inf), axis=1)
        score = (ctg + cfg.heading_weight * head + cfg.clearance_weight * np.maximum(cfg.clearance_soft - minclear, 0)
                 / max(cfg.clearance_soft, 1e-9) + cfg.spin_weight * np.abs(W) + cfg.reverse_weight * np.maximum(-V, 0))
        score = np.where(admissible, score, np.inf)
        k = int(np.argmin(score))
        if not np.isfinite(score[k]):
            return DwaChoice(0.0, 0.0, 0, math.inf, float(minclear.max(initial=0.0)))
        return DwaChoice(float(V[k]), float(W[k]), int(admissible.sum()), float(score[k]), float(minclear[k]))

    def _clearance(self, flat: np.ndarray, omap: ObstacleMap) -> np.ndarray:
        """Footprint-to-obstacle distance at every pose; poses whose centre is far from everything get the
        (lower-bound) distance-field value without the exact test."""
        fp = self.fp
        dist = omap.distance_field()
        rows, cols = omap.cells(flat[:, :2] + np.column_stack([np.cos(flat[:, 2]), np.sin(flat[:, 2])]) * fp.x_offset)
        ok = omap.inside(rows, cols)
        centre_d = np.zeros(len(flat))
        centre_d[ok] = dist[rows[ok], cols[ok]]
        bound = centre_d - omap.resolution * 0.75 - math.hypot(*fp.half)  # lower bound on footprint distance
        out = np.where(ok, np.maximum(bound, 0.0), 0.0)
        exact = ok & (bound < self.margin + self.cfg.clearance_soft)
        if exact.any():
            reach = math.hypot(*fp.half) + self.margin + self.cfg.clearance_soft
            out[exact] = np.minimum(fp.distances_near(flat[exact], omap.tree(), omap.points, reach),
                                    self.margin + self.cfg.clearance_soft)
        return out


def _rollouts(pose: Pose2D, v: np.ndarray, w: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(K, T, 3) poses of constant-twist arcs from `pose` at times t (exact unicycle integration)."""
    th = pose.yaw + w[:, None] * t[None, :]
    straight = np.abs(w) < 1e-6
    ws = np.where(straight, 1.0, w)[:, None]
    x = np.where(straight[:, None], pose.x + v[:, None] * t * math.cos(pose.yaw),
                 pose.x + v[:, None] / ws * (np.sin(th) - math.sin(pose.yaw)))
    y = np.where(straight[:, None], pose.y + v[:, None] * t * math.sin(pose.yaw),
                 pose.y - v[:, None] / ws * (np.cos(th) - math.cos(pose.yaw)))
    return np.stack([x, y, th], axis=-1)


def _gradient(field: NavField, xy: np.ndarray, h: float) -> np.ndarray:
    dx, dy = np.array([h, 0.0]), np.array([0.0, h])
    gx = field.value(xy + dx) - field.value(xy - dx)
    gy = field.value(xy + dy) - field.value(xy - dy)
    return np.column_stack([gx, gy]) / (2 * h)
