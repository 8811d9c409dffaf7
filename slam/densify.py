"""Constraint densification over the optimised graph (Cartographer's / slam_toolbox's continuous constraint
search), run when the log ends.

Loop closures are searched while driving, from a drifted estimate, so they are few: one per 0.8 m at best,
and only against submaps that pass a descriptor gate. A stretch of path whose only link to the map around it
is one weak group of closures hangs on that group. Once the graph is optimised, every pose is close to where
it belongs, so each keyframe can be matched against the map of its spatial neighbours in the estimate — places
visited at a different time, wherever they are along the path — in a small window, and every verified match
becomes one more constraint. Many independent constraints average out the error of any single one.

The neighbours' map is rebuilt from the optimised poses (not the frozen loop submaps, whose inner geometry is
as drifted as the estimate was when they were frozen): by default every scan within `spatial_map` of the
nearest anchor, from every pass, except the keyframe's own stretch of path; the constraint joins the keyframe
to that anchor, the map frozen in the anchor's frame (as Cartographer ties a node to a submap). Matches are
verified as strictly as loop closures (branch-and-bound score, ICP inliers and RMSE), added together with the
robust kernel, and any that is still inconsistent after optimising is removed again.

It runs once, when the log ends (`LogSlam.finish`): the online estimate, and so the loop search, is unchanged.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from typing import TYPE_CHECKING

import numpy as np
from pydantic import Field

from sim.config import StrictModel
from sim.transforms import se2_between
from slam import se2
from slam.csm import MatchGrid, search, thin
from slam.densify_groups import add_groups, coverage_matches
from slam.icp import IcpTarget, icp

if TYPE_CHECKING:
    from slam.log_slam import LogSlam


class DensifyConfig(StrictModel):
    enabled: bool = True
    every_distance: float = Field(2.0, gt=0, description="a keyframe every this much path is matched, m")
    neighbour_radius: float = Field(3.0, gt=0, description="anchors of the neighbours' maps: within this of the "
                                    "keyframe in the optimised estimate, m")
    min_path_separation: float = Field(10.0, gt=0, description="… and at least this far along the path (nearer "
                                       "is the front end's local map), m")
    map_distance: float = Field(4.0, gt=0, description="a neighbours' map: scans within ± this path length of "
                                "its anchor, at their optimised poses, m")
    spatial_map: float | None = Field(5.0, gt=0, description="instead: every scan within this distance of the "
                                      "anchor in the estimate, from any pass, except those within "
                                      "`min_path_separation` / 2 of the keyframe along the path, m")
    anchor_spacing: float = Field(2.0, gt=0, description="an anchor every this much path, m")
    per_keyframe: int = Field(1, ge=1, description="neighbours' maps matched per keyframe (nearest first)")
    window_xy: float = Field(0.5, gt=0, description="search ± this around the estimate, m")
    window_yaw: float = Field(math.radians(8), gt=0, description="rad")
    points: int = Field(120, ge=10, description="scan points scored by the search")
    passes: int = Field(1, ge=1, description="match, optimise; repeated from the new estimate")
    coverage_groups: bool = Field(True, description="then re-try long-range coverage matches against submaps "
                                  "rebuilt at the optimised poses, added only as agreeing groups "
                                  "(`slam.densify_groups`)")
    coverage_every: float = Field(1.0, gt=0, description="… a keyframe every this much path, m")
    coverage_radius: float = Field(1.5, gt=0, description="… searched ± this around the estimate, m")
    coverage_unlinked: float = Field(3.0, gt=0, description="… only keyframes with no loop closure or densified "
                                     "constraint ending within this much path (the stretches that hang on the "
                                     "chain alone), m")


class Densifier:
    def __init__(self, config: DensifyConfig, slam: LogSlam) -> None:
        self.config = config
        self.slam = slam
        self.added = 0
        self.rejected = 0
        self.constraints: list[tuple[int, int, se2.PoseTuple]] = []  # (anchor, keyframe, keyframe in anchor frame)
        self.group_added = 0  # coverage matches added in agreeing groups
        self.group_candidates = 0  # … out of this many verified

    def run(self) -> None:
        for _ in range(self.config.passes):
            if not self._pass():
                break
        if self.config.coverage_groups and self.slam.config.loops.coverage:
            s, lc = self.slam, self.slam.config.loops
            path = np.array(s.path)
            ends = [e for c in s.loops.active.values() for e in (c.source, c.target)]
            ends += [e for a, i, _ in self.constraints for e in (a, i)]
            linked = np.sort(path[ends]) if ends else np.zeros(0)
            keys = [k for k in _every(path, self.config.coverage_every) if len(s.points[k]) >= lc.min_points
                    and not _near(linked, path[k], self.config.coverage_unlinked)]
            matches = coverage_matches(s, self.config, keys)
            kept = add_groups(s, matches)
            self.group_candidates, self.group_added = len(matches), len(kept)
            self.constraints.extend((p.target, p.source, p.relative) for p in kept)

    def _pass(self) -> bool:
        c, s, lc = self.config, self.slam, self.slam.config.loops
        poses, path = np.array(s.poses), np.array(s.path)
        anchors = _every(path, c.anchor_spacing)
        keys = [k for k in _every(path, c.every_distance) if len(s.points[k]) >= lc.min_points]
        have = {(cl.target, cl.source) for cl in s.loops.active.values()} | {(a, i) for a, i, _ in self.constraints}
        maps: OrderedDict[tuple[int, int], tuple[MatchGrid, IcpTarget]] = OrderedDict()  # the recent ones only
        floor = np.diag([lc.sigma_floor_xy ** 2, lc.sigma_floor_xy ** 2, lc.sigma_floor_yaw ** 2])
        found: list[tuple[int, int, se2.PoseTuple, np.ndarray]] = []
        for i in keys:
            d = np.hypot(poses[anchors, 0] - poses[i, 0], poses[anchors, 1] - poses[i, 1])
            near = [(float(d[n]), a) for n, a in enumerate(anchors) if d[n] <= c.neighbour_radius
                    and abs(path[i] - path[a]) >= c.min_path_separation and (a, i) not in have]
            for _, a in sorted(near)[: c.per_keyframe]:
                key = (a, -1 if c.spatial_map is None else int(path[i] // (c.min_path_separation / 4)))
                if key not in maps:
                    built = self._map(a, i, poses, path)
                    if built is None:  # its scans saw nothing (a laser blackout)
                        continue
                    maps[key] = built
                    if len(maps) > _MAPS_KEPT:  # bounded memory on long logs (a grid is ~0.3–1 MB)
                        maps.popitem(last=False)
                maps.move_to_end(key)
                grid, target = maps[key]
                guess = se2_between(s.poses[a], s.poses[i])
                pts = s.points[i]
                sub = pts[np.linspace(0, len(pts) - 1, min(len(pts), c.points)).astype(int)]
                res = search(grid, sub, guess, window_xy=c.window_xy, window_yaw=c.window_yaw,
                             min_score=lc.min_score, max_range_for_step=10.0)
                if res is None:
                    continue
                fit = icp(pts, target, res.pose, max_correspondence=2 * lc.resolution, inlier_distance=0.1,
                          range_sigma=0.05)
                if not (fit.converged and fit.rmse <= lc.max_rmse and fit.inlier_ratio >= lc.min_inliers):
                    continue
                found.append((a, i, fit.pose, np.linalg.inv(fit.information + 1e-9 * np.eye(3)) + floor))
        if not found:
            return False
        g = s.graph
        added = {g.add_between(a, i, rel, cov, lc.kernel, lc.kernel_width): (a, i, rel, cov)
                 for a, i, rel, cov in found}
        g.converge(max_steps=50)
        bad = [k for k in added if not g.removed(k) and g.chi2(k) > lc.residual_chi2]
        for k in bad:
            g.remove(k)
        if bad:
            g.converge(max_steps=50)
        kept = [k for k in added if not g.removed(k)]
        s.edges.extend(added[k] for k in kept)  # for graph.g2o
        self.constraints.extend(added[k][:3] for k in kept)
        self.added += len(kept)
        self.rejected += len(added) - len(kept)
        s.refresh_poses()
        return True

    def _map(self, a: int, i: int, poses: np.ndarray, path: np.ndarray) -> tuple[MatchGrid, IcpTarget] | None:
        """The scans around anchor a at their optimised poses, in a's frame."""
        c, s, lc = self.config, self.slam, self.slam.config.loops
        if c.spatial_map is None:
            idx = np.nonzero(np.abs(path - path[a]) <= c.map_distance)[0]
        else:
            near = np.hypot(poses[:, 0] - poses[a, 0], poses[:, 1] - poses[a, 1]) <= c.spatial_map
            idx = np.nonzero(near & (np.abs(path - path[i]) >= c.min_path_separation / 2))[0]
            idx = idx[np.unique(np.floor(path[idx] / 0.3), return_index=True)[1]]  # one scan per 0.3 m of path
        if len(idx) > 40:
            idx = idx[np.linspace(0, len(idx) - 1, 40).astype(int)]
        rel = se2.between_many(np.tile(poses[a], (len(idx), 1)), poses[idx])
        pts = np.vstack([se2.transform_points(tuple(rel[n]), s.points[k]) for n, k in enumerate(idx)])
        if len(pts) < 10:
            return None
        pts = thin(pts, lc.resolution / 2)
        return MatchGrid(pts, lc.resolution, lc.sigma, margin=c.window_xy + 1.0), IcpTarget.from_points(pts)


_MAPS_KEPT = 64  # keyframes come in path order: a neighbours' map is reused by the next few, rarely later


def _every(path: np.ndarray, spacing: float) -> list[int]:
    """Indices of the first node of every `spacing` of path."""
    out, last = [], -math.inf
    for k, p in enumerate(path):
        if p - last >= spacing:
            out.append(k)
            last = p
    return out


def _near(sorted_values: np.ndarray, x: float, gap: float) -> bool:
    """Whether any of `sorted_values` is within `gap` of x."""
    n = int(np.searchsorted(sorted_values, x))
    return any(abs(float(sorted_values[m]) - x) <= gap for m in (n - 1, n) if 0 <= m < len(sorted_values))
