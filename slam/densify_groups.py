"""Long-range links re-tried at the end of the log, against maps rebuilt at the optimised poses, and added only
as agreeing groups (`slam.densify`'s second stage).

Some stretches of a log are tied to the rest of the map only by what the scanner sees from far away: a
corridor entered at its other end, 20 m from where it was mapped (Radish edmonton, scans 150–155 → 51). Those
coverage matches are weak (mean hit likelihood 0.35–0.5), so online they are kept only when a loop group agrees
(`slam.loop_groups`), and whether three of them pass the weak gates while the robot drives by decides between
two outcomes of the whole log (edmonton: 0.14 m or 0.6 m). Measured in the 0.6 m run: once the log has ended,
the same keyframes matched against the coverage submaps rebuilt at the optimised poses land within 3–15 cm of
the reference, from an estimate 0.8–1.1 m off, and a dozen of them agree.

So every keyframe (`coverage_every`) is matched once more against the longest-loop coverage submap it sees,
with the online verification (weak gates, ICP, distinctness); the matches are pooled and only a set that
agrees pairwise (at least `groups.min_size`) is added, kept if it fits without breaking an accepted closure.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from sim.transforms import se2_between
from slam.csm import search
from slam.icp import icp
from slam.log_loops import Submap
from slam.loop_batch import BuiltCache
from slam.loop_coverage import rival
from slam.loop_groups import Pending, largest_group

if TYPE_CHECKING:
    from slam.densify import DensifyConfig
    from slam.log_slam import LogSlam


def coverage_matches(slam: LogSlam, config: DensifyConfig, keys: list[int]) -> list[Pending]:
    """Verified coverage matches (weak ones too) of `keys` against submaps rebuilt at the optimised poses."""
    s, c = slam, slam.config.loops
    path, poses = np.array(s.path), s.poses
    have = {(cl.target, cl.source) for cl in s.loops.active.values()}
    built: dict[int, Submap] = {}
    cache = BuiltCache(c.max_built)
    floor = np.diag([c.sigma_floor_xy ** 2, c.sigma_floor_xy ** 2, c.sigma_floor_yaw ** 2])
    radius = config.coverage_radius
    out: list[Pending] = []
    for i in keys:
        pts = s.points[i]
        probe = pts[np.linspace(0, len(pts) - 1, min(len(pts), 120)).astype(int)]
        best: tuple[float, int] | None = None
        for a, sm in s.loops.wide.items():
            sep = abs(path[i] - path[a])
            if sep < c.min_path_separation + c.coverage_submap_distance or (a, i) in have or sm.coverage is None:
                continue
            if math.hypot(poses[a][0] - poses[i][0], poses[a][1] - poses[i][1]) > c.coverage_reach:
                continue
            if float(sm.coverage.covered(probe, se2_between(poses[a], poses[i]), radius).mean()) \
                    >= c.coverage_min_share and (best is None or sep > best[0]):
                best = (sep, a)  # the longest loop: it bounds the most drift
        if best is None:
            continue
        a = best[1]
        if a not in built:
            idx = np.nonzero(np.abs(path - path[a]) <= c.coverage_submap_distance)[0]
            idx = idx[np.linspace(0, len(idx) - 1, min(len(idx), 40)).astype(int)]
            built[a] = Submap(a, [(se2_between(poses[a], poses[k]), s.points[k]) for k in idx], np.zeros(1),
                              c.resolution, c.sigma, c.radius_max + 1.0, coverage=True)
        sm = built[a]
        cache.touch(a, sm)  # long logs: only the recently used keep their match grids
        assert sm.coverage is not None
        guess = se2_between(poses[a], poses[i])
        seen = pts[sm.coverage.covered(pts, guess, radius)]
        if len(seen) < c.min_points:
            continue
        sub = seen[np.linspace(0, len(seen) - 1, min(len(seen), c.coverage_points)).astype(int)]
        weak = c.weak_min_score if c.weak_min_score is not None else c.min_score
        res = search(sm.grid, sub, guess, window_xy=radius, window_yaw=c.yaw_window,
                     max_range_for_step=c.coverage_angle_range, min_score=min(weak, c.min_score))
        if res is None:
            continue
        fit = icp(seen, sm.target, res.pose, max_correspondence=2 * c.resolution, inlier_distance=0.1,
                  range_sigma=0.05)
        if not (fit.converged and fit.rmse <= c.max_rmse and fit.inlier_ratio >= c.weak_min_inliers):
            continue
        if rival(sm.grid, sub, fit.pose, radius) > c.weak_max_rival * res.score:
            continue  # not distinct: a corridor's walls fit anywhere along it
        cov = np.linalg.inv(fit.information + 1e-9 * np.eye(3)) + floor
        out.append(Pending(a, i, fit.pose, cov, res.score, fit.inlier_ratio, fit.rmse))
    return out


def add_groups(slam: LogSlam, matches: list[Pending]) -> list[Pending]:
    """Add the largest pairwise-agreeing sets of `matches` (each at least `groups.min_size`), one at a time;
    a set stays only if it fits and no accepted closure breaks. Returns the matches kept."""
    s, lc = slam, slam.config.loops
    gc = lc.groups
    kept: list[Pending] = []
    for cluster in _clusters(matches, s.path, gc.max_span):
        while len(cluster) >= gc.min_size:
            best = max((largest_group(cluster, n, s.poses, s.path, gc) for n in range(len(cluster))), key=len)
            if len(best) < gc.min_size:
                break
            taken = set(best)
            kept.extend(_try(slam, [cluster[n] for n in best]))
            cluster = [p for n, p in enumerate(cluster) if n not in taken]
    s.refresh_poses()
    return kept


def _clusters(matches: list[Pending], path: list[float], span: float) -> list[list[Pending]]:
    """Matches split where their sources are more than `span` apart along the path (they cannot agree)."""
    out: list[list[Pending]] = []
    for p in sorted(matches, key=lambda p: path[p.source]):
        if out and path[p.source] - path[out[-1][-1].source] <= span:
            out[-1].append(p)
        else:
            out.append([p])
    return out


def _try(slam: LogSlam, members: list[Pending]) -> list[Pending]:
    """Add a group; keep the members that fit if at least `min_size` do and no accepted closure breaks."""
    s, lc, g = slam, slam.config.loops, slam.graph
    gc = lc.groups
    active = [k for k in s.loops.active if not g.removed(k)]
    added = {g.add_between(p.target, p.source, p.relative, p.covariance, lc.kernel, lc.kernel_width): p
             for p in members}
    g.converge(max_steps=50)
    fits = [k for k in added if not g.removed(k) and g.chi2(k) <= lc.residual_chi2]
    broken = [k for k in active if g.chi2(k) > lc.residual_chi2]
    if len(fits) < gc.min_size or broken:
        for k in added:
            g.remove(k)
        g.converge(max_steps=50)
        return []
    for k in set(added) - set(fits):
        g.remove(k)
    g.converge(max_steps=50)
    s.edges.extend((added[k].target, added[k].source, added[k].relative, added[k].covariance) for k in fits)
    s.refresh_poses()
    return [added[k] for k in fits]
