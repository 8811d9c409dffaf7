"""`orca`: Optimal Reciprocal Collision Avoidance for differential-drive robots.

Each robot is reduced to a holonomic point `offset` metres ahead of its axle, whose planar velocity maps
one-to-one to (v, ω) (u = v·h + offset·ω·h⊥), inflated to radius footprint + offset + margin so its disc
holds the whole robot. ORCA half-planes are built for all neighbour pairs at once (numpy); each robot's 2D
linear program (fleet/avoidance/lp.py) then picks the allowed velocity closest to what its navigator wanted.
Robots driven by autonomy share the avoidance (½ each); passive robots (idle, manual, e-stopped) are
avoided fully. While a robot dodges, the nearest static obstacle adds a hard half-plane (approach no faster
than its navigator did, or than the clearance allows within `obstacle_time_horizon`), so dodging a robot
never means driving into a shelf.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from pydantic import Field
from scipy.spatial import cKDTree

from fleet.avoidance.clearance import StaticClearance
from fleet.avoidance.frame import fleet_frame
from fleet.avoidance.intent import preferred_velocities
from fleet.avoidance.lp import Line, solve
from fleet.avoidance.registry import Command, register_avoidance
from fleet.avoidance.types import AvoidanceConfig, FleetFrame

if TYPE_CHECKING:
    from fleet.fleet_view import FleetView


class OrcaConfig(AvoidanceConfig):
    type: str = "orca"
    time_horizon: float = Field(2.0, gt=0, description="robots are avoided this far ahead in time, s")
    obstacle_time_horizon: float = Field(1.0, gt=0, description="same for static obstacles, s")
    neighbor_dist: float = Field(4.0, gt=0, description="robots farther than this (centre to centre) are ignored, m")
    max_neighbors: int = Field(10, ge=1, le=100)
    radius_margin: float = Field(0.05, ge=0, description="added to each robot's footprint radius, m")
    offset: float = Field(0.15, gt=0, le=1.0, description="tracked point ahead of the axle, m")
    head_on_angle: float = Field(0.35, ge=0, le=1.5, description="closing within this angle of the line of "
                                 "centres counts as head-on: keep right instead of both braking, rad")
    lookahead: float = Field(1.0, gt=0, description="a go-to robot prefers the direction to this far along its path, m")
    min_speed: float = Field(0.3, ge=0, description="...at least this fast while it has a path to follow, m/s")
    wall_gap: float = Field(0.15, ge=0, description="closer than this to a static obstacle (footprint edge) a "
                            "robot is only slowed, never steered, m")


@register_avoidance("orca", OrcaConfig)
class OrcaFilter:
    name = "orca"

    def __init__(self, *, time_horizon: float = 2.0, obstacle_time_horizon: float = 1.0, neighbor_dist: float = 4.0,
                 max_neighbors: int = 10, radius_margin: float = 0.05, offset: float = 0.15,
                 head_on_angle: float = 0.35, lookahead: float = 1.0, min_speed: float = 0.3,
                 wall_gap: float = 0.15) -> None:
        self.tau, self.tau_obst = time_horizon, obstacle_time_horizon
        self.neighbor_dist, self.max_neighbors = neighbor_dist, max_neighbors
        self.margin, self.offset = radius_margin, offset
        self.head_on_cos = float(np.cos(head_on_angle))
        self.lookahead, self.min_speed, self.wall_gap = lookahead, min_speed, wall_gap
        self.adjusted = 0  # commands changed, over the filter's life (diagnostics)

    def settings(self) -> dict[str, Any]:
        return {"type": self.name, "time_horizon": self.tau, "obstacle_time_horizon": self.tau_obst,
                "neighbor_dist": self.neighbor_dist, "max_neighbors": self.max_neighbors,
                "radius_margin": self.margin, "offset": self.offset,
                "head_on_angle": float(np.arccos(self.head_on_cos)), "lookahead": self.lookahead,
                "min_speed": self.min_speed, "wall_gap": self.wall_gap}

    def filter(self, view: FleetView, desired: dict[str, Command]) -> dict[str, Command]:
        frame = fleet_frame(view, desired)
        pref = preferred_velocities(view, frame, self.offset, self.lookahead, self.min_speed)
        out = self.solve(frame, view.control_dt, view.static_clearance(), pref)
        return {n: (float(out[i, 0]), float(out[i, 1])) for i, n in enumerate(frame.names) if n in desired}

    # ---- the algorithm (pure: arrays in, arrays out) ------------------------------------------------------

    def solve(self, fr: FleetFrame, dt: float, clearance: StaticClearance | None = None,
              pref: np.ndarray | None = None) -> np.ndarray:
        """New (v, ω) for every robot of the frame: (n, 2). `pref`: preferred velocities of the tracked points
        (default: the commands mapped to them); a robot whose preference is allowed keeps its command."""
        n, off = len(fr.names), self.offset
        out = fr.cmd.copy()
        if n == 0:
            return out
        h = np.column_stack([np.cos(fr.yaw), np.sin(fr.yaw)])
        hp = np.column_stack([-h[:, 1], h[:, 0]])
        p = fr.xy + off * h  # the holonomic points
        vel = fr.v[:, None] * h + (off * fr.w)[:, None] * hp
        if pref is None:
            pref = fr.cmd[:, 0:1] * h + off * fr.cmd[:, 1:2] * hp
        rad = fr.radius + off + self.margin
        speed = np.hypot(fr.max_v, off * fr.max_w)  # every command within the limits fits in this disc
        pairs = self._neighbours(fr.xy, fr.active)
        g = fr.group[pairs[:, 0]]
        pairs = pairs[(g < 0) | (g != fr.group[pairs[:, 1]])]  # a self-separating swarm handles its own
        agent_lines = self._agent_lines(pairs, p, vel, rad, fr.active, dt)
        gap = clearance.query(fr.xy)[0] - fr.radius if clearance is not None else np.full(n, np.inf)
        obst_lines = self._obstacle_lines(fr, clearance)
        for i in np.flatnonzero(fr.active):
            agents = agent_lines.get(int(i))
            want = (float(pref[i, 0]), float(pref[i, 1]))
            if agents is None or _same(solve(agents, 0, float(speed[i]), want), want):
                continue  # no robot in the way: the navigator's command goes through exactly (walls are its job)
            lines = obst_lines.get(int(i), [])
            hard = len(lines)
            lines = lines + agents
            u = solve(lines, hard, float(speed[i]), want)
            biased = self._keep_right(int(i), pref[i], p, pairs)
            if biased is not None:
                u = solve(lines, hard, float(speed[i]), biased)
            self.adjusted += 1
            v = float(np.clip(u[0] * h[i, 0] + u[1] * h[i, 1], -fr.max_v[i], fr.max_v[i]))
            w = float(np.clip((u[0] * hp[i, 0] + u[1] * hp[i, 1]) / off, -fr.max_w[i], fr.max_w[i]))
            out[i] = (v, w) if gap[i] >= self.wall_gap else _brake_only(fr.cmd[i], v)
        return out

    def _keep_right(self, i: int, pref: np.ndarray, p: np.ndarray, pairs: np.ndarray) -> tuple[float, float] | None:
        """Head-on, ORCA's cut-off constraint only brakes and two robots stop nose to nose (the classic
        symmetric deadlock). When the preference points within `head_on_angle` of a neighbour, turn it to pass
        that neighbour on the right; every robot doing the same is a consistent traffic rule."""
        speed = float(np.hypot(*pref))
        if speed < 1e-6:
            return None
        js = pairs[pairs[:, 0] == i, 1]
        rel = p[js] - p[i]
        cos = rel @ pref / np.maximum(np.hypot(rel[:, 0], rel[:, 1]) * speed, 1e-12)
        ahead = np.flatnonzero(cos > self.head_on_cos)
        if not len(ahead):
            return None
        k = ahead[0]  # pairs are nearest first
        ang = float(np.arctan2(rel[k, 1], rel[k, 0])) - float(np.arccos(self.head_on_cos))
        return speed * float(np.cos(ang)), speed * float(np.sin(ang))

    def _neighbours(self, xy: np.ndarray, active: np.ndarray) -> np.ndarray:
        """(m, 2) index pairs (i, j): j is among i's nearest neighbours within range, i active; nearest first."""
        n = len(xy)
        if n < 2 or not active.any():
            return np.zeros((0, 2), dtype=np.int64)
        k = min(n, self.max_neighbors + 1)
        src = np.flatnonzero(active)
        d, j = cKDTree(xy).query(xy[src], k=k, distance_upper_bound=self.neighbor_dist)
        i = np.repeat(src, k).reshape(len(src), k)
        ok = np.isfinite(d) & (j != i)
        return np.column_stack([i[ok], j[ok]])

    def _agent_lines(self, pairs: np.ndarray, p: np.ndarray, vel: np.ndarray, rad: np.ndarray,
                     active: np.ndarray, dt: float) -> dict[int, list[Line]]:
        """RVO2's ORCA half-planes for all pairs at once (see Agent::computeNewVelocity)."""
        if not len(pairs):
            return {}
        i, j = pairs[:, 0], pairs[:, 1]
        rel_pos, rel_vel = p[j] - p[i], vel[i] - vel[j]
        dist_sq = np.einsum("ij,ij->i", rel_pos, rel_pos)
        comb = rad[i] + rad[j]
        comb_sq = comb * comb
        collide = dist_sq <= comb_sq
        inv = np.where(collide, 1.0 / dt, 1.0 / self.tau)  # already touching: resolve within one control step
        w = rel_vel - inv[:, None] * rel_pos
        w_len_sq = np.einsum("ij,ij->i", w, w)
        dot1 = np.einsum("ij,ij->i", w, rel_pos)
        cutoff = collide | ((dot1 < 0) & (dot1 * dot1 > comb_sq * w_len_sq))
        # project on the cut-off circle (or, when colliding, on the circle reached in one step)
        w_len = np.sqrt(np.maximum(w_len_sq, 1e-18))
        unit_w = w / w_len[:, None]
        direction = np.column_stack([unit_w[:, 1], -unit_w[:, 0]])
        u = ((comb * inv - w_len)[:, None]) * unit_w
        # otherwise project on the nearer leg of the cone
        leg = np.sqrt(np.maximum(dist_sq - comb_sq, 0.0))
        left = (rel_pos[:, 0] * w[:, 1] - rel_pos[:, 1] * w[:, 0]) > 0
        rx, ry = rel_pos[:, 0], rel_pos[:, 1]
        safe_sq = np.maximum(dist_sq, 1e-18)
        dl = np.column_stack([rx * leg - ry * comb, rx * comb + ry * leg]) / safe_sq[:, None]
        dr = -np.column_stack([rx * leg + ry * comb, -rx * comb + ry * leg]) / safe_sq[:, None]
        leg_dir = np.where(left[:, None], dl, dr)
        leg_u = np.einsum("ij,ij->i", rel_vel, leg_dir)[:, None] * leg_dir - rel_vel
        direction = np.where(cutoff[:, None], direction, leg_dir)
        u = np.where(cutoff[:, None], u, leg_u)
        share = np.where(active[j], 0.5, 1.0)
        point = vel[i] + share[:, None] * u
        lines: dict[int, list[Line]] = {}
        for k, a in enumerate(i.tolist()):
            lines.setdefault(a, []).append((float(point[k, 0]), float(point[k, 1]),
                                            float(direction[k, 0]), float(direction[k, 1])))
        return lines

    def _obstacle_lines(self, fr: FleetFrame, clearance: StaticClearance | None) -> dict[int, list[Line]]:
        """While dodging a robot, the axle centre approaches the nearest static obstacle no faster than its
        navigator's command already did, or than (clearance − radius − margin)/τ_obst allows: avoidance never
        pushes a robot into a shelf, and never stops it where its own path takes it close to one.

        The centre moves at v·h with v = u·h, so its approach speed is (u·h)(h·n): a half-plane in u with
        normal sign(h·n)·h. (Constraining the tracked point instead would let a turn carry the centre in.)"""
        if clearance is None:
            return {}
        dist, normal = clearance.query(fr.xy)
        reach = fr.radius + fr.max_v * self.tau_obst
        near = np.flatnonzero(fr.active & (dist < reach) & (np.abs(normal).sum(axis=1) > 0))
        lines: dict[int, list[Line]] = {}
        for i in near.tolist():
            hx, hy = float(np.cos(fr.yaw[i])), float(np.sin(fr.yaw[i]))
            facing = hx * float(normal[i, 0]) + hy * float(normal[i, 1])
            if abs(facing) < 0.05:
                continue  # side-on: driving does not bring the centre closer
            safe = max(0.0, (dist[i] - fr.radius[i] - self.margin) / self.tau_obst)
            b = max(safe, float(fr.cmd[i, 0]) * facing) / abs(facing)
            nx, ny = (hx, hy) if facing > 0 else (-hx, -hy)
            lines[i] = [(b * nx, b * ny, -ny, nx)]
        return lines


def _same(a: tuple[float, float], b: tuple[float, float]) -> bool:
    return abs(a[0] - b[0]) + abs(a[1] - b[1]) < 1e-9


def _brake_only(cmd: np.ndarray, v: float) -> tuple[float, float]:
    """Next to a shelf a dodge (a turn) would swing the footprint's corners into it: only slow the robot down
    along its navigator's own arc (v and ω scaled alike), never steer it; a turn on the spot goes through."""
    v_nav, w_nav = float(cmd[0]), float(cmd[1])
    if abs(v_nav) < 1e-6:
        return v_nav, w_nav
    k = min(max(v / v_nav, 0.0), 1.0)
    return v_nav * k, w_nav * k
