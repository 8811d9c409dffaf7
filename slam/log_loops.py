"""Loop closure for `LogSlam`: submaps along the path, candidates by pose uncertainty and descriptor,
verification by branch-and-bound correlative matching + ICP, a robust GTSAM factor, and a consistency
check after optimising (a closure still inconsistent with the rest of the graph is removed again).

A submap is the scans within ±`submap_distance` of path around an anchor scan, frozen in the anchor's
frame once the robot has driven past it. The search radius around the current estimate grows with the
path driven since the submap (or since the last accepted closure, whichever is shorter): that is how far
odometry drift can have carried the estimate. Where no submap passes the proximity and descriptor gates,
longer submaps that cover what the scan sees are tried instead, whatever the heading (`slam.loop_coverage`):
their matches must stand out from shifted poses, and a weak one waits for a loop group to agree with it.
"""

from __future__ import annotations

import bisect
import math
from collections import Counter
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from sim.transforms import se2_between
from slam import se2
from slam.csm import search
from slam.icp import icp
from slam.loop_batch import AnchorTable, BuiltCache, chi2_at, within
from slam.loop_blind import WideGrids, distinct, widening
from slam.loop_closure import descriptor_distance, ring_descriptor
from slam.loop_coverage import rival
from slam.loop_groups import Pending, largest_group
from slam.loop_submap import Submap
from slam.loop_switch import named_edges, switch_edge, unswitch
from slam.pose_graph import IndeterminateGraph, Kernel

if TYPE_CHECKING:
    from slam.log_config import LoopConfig
    from slam.log_slam import LogSlam


@dataclass(frozen=True, slots=True)
class Closure:
    source: int  # the new scan
    target: int  # the submap's anchor scan
    relative: se2.PoseTuple  # source in target's frame
    score: float  # branch-and-bound score (0 if not matched)
    inliers: float
    rmse: float
    accepted: bool
    reason: str

    def as_dict(self) -> dict[str, object]:
        return {"source": self.source, "target": self.target, "relative": [round(v, 4) for v in self.relative],
                "score": round(self.score, 3), "inliers": round(self.inliers, 3),
                "rmse": round(self.rmse, 4) if math.isfinite(self.rmse) else None,
                "accepted": self.accepted, "reason": self.reason}


class LoopFinder:
    def __init__(self, config: LoopConfig, slam: LogSlam) -> None:
        self.config = config
        self.slam = slam
        self.anchors: list[int] = []
        self.submaps: dict[int, Submap] = {}
        self.wide: dict[int, Submap] = {}  # longer submaps for coverage candidates (`slam.loop_coverage`)
        self.history: list[Closure] = []
        self.reasons: Counter[str] = Counter()
        self._last_try = -math.inf
        self._last_closure_path = 0.0
        self._descriptors: dict[int, np.ndarray] = {}
        self.active: dict[int, Closure] = {}  # graph factor index → accepted closure still in the graph
        self._edge: dict[int, tuple[int, int, se2.PoseTuple, np.ndarray]] = {}
        self.pending: list[Pending] = []  # verified but inconsistent closures (`slam.loop_groups`)
        self.switched: list[int] = []  # front-end edges moved to their alternative peak by a loop group
        self._floor = np.diag([config.sigma_floor_xy ** 2, config.sigma_floor_xy ** 2, config.sigma_floor_yaw ** 2])
        self._frozen = [0, 0]  # anchors[:n] have their submap / coverage submap (anchors are in path order)
        self._tables = (AnchorTable(), AnchorTable())  # submaps', coverage submaps' anchors
        self._cache = BuiltCache(config.max_built)
        self.deferred: list[int] = []  # factor indices of closures added without optimising (`slam.loop_batch`)
        self._deferred_since = math.inf
        self._widened = WideGrids()  # grids for windows widened by blind path

    @property
    def accepted(self) -> int:
        """Closures in the graph now."""
        return len(self.active)

    def descriptor(self, i: int) -> np.ndarray:
        if i not in self._descriptors:
            self._descriptors[i] = ring_descriptor(self.slam.points[i], self.config.descriptor_rings,
                                                   self.slam.config.mapping.max_range)
        return self._descriptors[i]

    def step(self, i: int) -> None:
        c, s = self.config, self.slam
        path = s.path
        if (not self.anchors or path[i] - path[self.anchors[-1]] >= c.submap_spacing) and len(s.points[i]):
            # (a blind scan anchors nothing: its submap could be empty)
            self.anchors.append(i)
        # freeze submaps the robot has driven past (anchors are in path order: the unfrozen ones are a suffix)
        for w, (store, dist) in enumerate(((self.submaps, c.submap_distance), (self.wide, c.coverage_submap_distance))):
            while (w == 0 or c.coverage) and self._frozen[w] < len(self.anchors) \
                    and path[i] - path[self.anchors[self._frozen[w]]] > dist:
                a = self.anchors[self._frozen[w]]
                store[a] = self._build(a, dist, coverage=w == 1)
                self._frozen[w] += 1
        if self.deferred and path[i] - self._deferred_since >= c.defer_distance:
            self.flush()
        if path[i] - self._last_try < c.every_distance or len(s.points[i]) < c.min_points:
            return
        self._last_try = path[i]
        for sm, radius, yaw in self.candidates(i):
            closure = self.verify(i, sm, radius, yaw)
            if closure.accepted:
                break

    def _build(self, a: int, distance: float, coverage: bool) -> Submap:
        s, c = self.slam, self.config
        lo = max(bisect.bisect_left(s.path, s.path[a] - distance) - 1, 0)  # path is non-decreasing: a slice
        hi = bisect.bisect_right(s.path, s.path[a] + distance) + 1
        path = np.array(s.path[lo:hi])
        idx = lo + np.nonzero(np.abs(path - s.path[a]) <= distance)[0]
        idx = idx[idx <= len(s.poses) - 1]
        if len(idx) > 40:
            idx = idx[np.linspace(0, len(idx) - 1, 40).astype(int)]
        anchor = s.poses[a]
        scans = [(se2_between(anchor, s.poses[k]), s.points[k]) for k in idx]  # poses frozen now
        return Submap(a, scans, self.descriptor(a), c.resolution, c.sigma, c.radius_max + 1.0, coverage)

    def candidates(self, i: int) -> list[tuple[Submap, float, float]]:
        """(submap, search radius, rotation window) of frozen submaps near scan i in the estimate, most similar
        first; if there are none and `coverage` is on, the long submaps that cover scan i (`slam.loop_coverage`).
        The radius grows with the path since the submap or the last closure (capped at `radius_max`), and beyond
        that with the *blind* path (unmatched steps) since then, which has no such bound on its drift."""
        c, s = self.config, self.slam
        path = s.path
        here = s.poses[i]
        found: list[tuple[float, int, float, float]] = []
        keys, apath, axy = self._tables[0].get(self.submaps, self.slam.poses, self.slam.path)
        sep = path[i] - apath
        drift = np.minimum(sep, path[i] - self._last_closure_path + c.submap_distance)
        extra, yaw = widening(c, s.blind, path, self._last_closure_path, i, keys)
        radius = np.minimum(c.radius_max, c.radius_base + c.radius_drift * drift) + extra
        dist = np.hypot(axy[:, 0] - here[0], axy[:, 1] - here[1]) if len(keys) else np.zeros(0)
        for n in np.nonzero((sep >= c.min_path_separation + c.submap_distance)
                            & (dist <= radius + c.submap_distance))[0]:
            a = int(keys[n])
            desc = float(descriptor_distance(self.submaps[a].descriptor, self.descriptor(i))[0])
            if desc > c.descriptor_max_distance:
                continue
            found.append((desc + 0.02 * float(dist[n]), a, float(radius[n]), float(yaw[n])))
        found.sort()
        if not found and c.coverage:
            return self._covering(i)
        return [(self.submaps[a], r, y) for _, a, r, y in found[: c.max_candidates]]

    def _covering(self, i: int) -> list[tuple[Submap, float, float]]:
        c, s = self.config, self.slam
        path, here, probe = s.path, s.poses[i], self._probe(i)
        found: list[tuple[float, int, float, float]] = []
        keys, apath, axy = self._tables[1].get(self.wide, self.slam.poses, self.slam.path)
        near = within(axy, here, c.coverage_reach) \
            & (path[i] - apath >= c.min_path_separation + c.coverage_submap_distance)
        extra, yaw = widening(c, s.blind, path, self._last_closure_path, i, keys[near])
        for a, e, y in zip(keys[near].tolist(), extra.tolist(), yaw.tolist(), strict=True):
            sm, sep, p = self.wide[a], path[i] - path[a], s.poses[a]
            if sm.coverage is None:
                continue
            drift = min(sep, path[i] - self._last_closure_path + c.coverage_submap_distance)
            radius = min(c.radius_max, c.radius_base + c.radius_drift * drift) + e
            if float(sm.coverage.covered(probe, se2_between(p, here), radius).mean()) >= c.coverage_min_share:
                found.append((-sep, a, radius, y))  # the longest loop first: it bounds the most drift
        found.sort()
        return [(self.wide[a], r, y) for _, a, r, y in found[: c.coverage_candidates]]

    def _probe(self, i: int) -> np.ndarray:
        pts = self.slam.points[i]
        return pts[np.linspace(0, len(pts) - 1, min(len(pts), 120)).astype(int)]

    def verify(self, i: int, sm: Submap, radius: float, yaw: float | None = None) -> Closure:
        c, s = self.config, self.slam
        a = sm.anchor
        guess = se2_between(s.poses[a], s.poses[i])
        pts = s.points[i]
        if sm.coverage is not None:  # verify on the returns the submap can explain
            pts = pts[sm.coverage.covered(pts, guess, radius)]
            if len(pts) < c.min_points:
                return self._record(Closure(i, a, guess, 0.0, 0.0, math.inf, False, "too_few_covered"))
        n, angle_range = (120, 10.0) if sm.coverage is None else (c.coverage_points, c.coverage_angle_range)
        self._cache.touch(2 * a + (sm.coverage is not None), sm)
        sub = pts[np.linspace(0, len(pts) - 1, min(len(pts), n)).astype(int)]
        weak = c.weak_min_score if sm.coverage is not None and self.config.groups.enabled else None
        widened = radius > c.radius_max + 1e-9 or (yaw is not None and yaw > c.yaw_window + 1e-9)
        grid = self._widened.get(sm, radius) if radius > c.radius_max + 1e-9 else sm.grid
        res = search(grid, sub, guess, window_xy=radius, window_yaw=c.yaw_window if yaw is None else yaw,
                     max_range_for_step=angle_range,
                     min_score=c.min_score if weak is None else min(weak, c.min_score))
        if res is None:
            return self._record(Closure(i, a, guess, 0.0, 0.0, math.inf, False, "no_match_above_min_score"))
        fit = icp(pts, sm.target, res.pose, max_correspondence=2 * c.resolution, inlier_distance=0.1,
                  range_sigma=0.05)
        strong = res.score >= c.min_score and fit.inlier_ratio >= c.min_inliers
        if not (fit.converged and fit.rmse <= c.max_rmse
                and (strong or (weak is not None and fit.inlier_ratio >= c.weak_min_inliers))):
            return self._record(Closure(i, a, fit.pose, res.score, fit.inlier_ratio, fit.rmse, False,
                                        "icp_fitness"))
        cov = np.linalg.inv(fit.information + 1e-9 * np.eye(3)) + self._floor
        if sm.coverage is not None and rival(sm.grid, sub, fit.pose, radius) > c.weak_max_rival * res.score:
            # a corridor's walls fit anywhere along it: the match must stand out (coverage has no descriptor)
            return self._record(Closure(i, a, fit.pose, res.score, fit.inlier_ratio, fit.rmse, False,
                                        "not_distinct"))
        if widened and not distinct(grid, sub, guess, res.pose, res.score, radius, yaw or c.yaw_window,
                                    c.blind_exclude_yaw, c.weak_max_rival, angle_range):
            # the blind path widened the window: aliases (a corridor's width, a square room's turn) fit in it
            return self._record(Closure(i, a, fit.pose, res.score, fit.inlier_ratio, fit.rmse, False,
                                        "not_distinct_blind"))
        if not strong:  # too little overlap to trust alone: only a group of agreeing closures may add it
            self._try_group(Pending(a, i, fit.pose, cov, res.score, fit.inlier_ratio, fit.rmse))
            return self._record(Closure(i, a, fit.pose, res.score, fit.inlier_ratio, fit.rmse, False,
                                        "weak_pending"))
        return self.add(a, i, fit.pose, cov, res.score, fit.inlier_ratio, fit.rmse)

    def add(self, target: int, source: int, relative: se2.PoseTuple, covariance: np.ndarray, score: float = 1.0,
            inliers: float = 1.0, rmse: float = 0.0) -> Closure:
        """Add a closure with the robust kernel, optimise, and remove it again if it stays inconsistent."""
        g, c = self.slam.graph, self.config
        if c.defer_chi2 is not None and len(self.slam.poses) > c.defer_after_nodes \
                and chi2_at(self.slam.poses, target, source, relative, covariance) <= c.defer_chi2:
            k = g.add_between(target, source, relative, covariance, self.kernel_for(target, source, relative),
                              c.kernel_width)  # queued: optimised with the next batch (`flush`)
            self.deferred.append(k)
            self._deferred_since = min(self._deferred_since, self.slam.path[source])
            self._last_closure_path = self.slam.path[source]
            closure = Closure(source, target, relative, score, inliers, rmse, True, "accepted")
            self._activate(k, closure, covariance)
            return self._record(closure)
        k = g.add_between(target, source, relative, covariance, self.kernel_for(target, source, relative),
                          self.config.kernel_width)
        g.converge(max_steps=20)
        self._check_deferred()
        if g.removed(k):  # GTSAM could not solve the graph with it (`PoseGraph._repair`)
            self._sync()
            self.slam.refresh_poses()
            return self._record(Closure(source, target, relative, score, inliers, rmse, False, "graph_indeterminate"))
        chi2 = g.chi2(k)
        if chi2 > self.config.residual_chi2:
            g.remove(k)
            g.converge(max_steps=20)
            self.slam.refresh_poses()
            rejected = self._record(Closure(source, target, relative, score, inliers, rmse, False,
                                            "inconsistent_after_optimisation"))
            if self.config.groups.enabled:
                self._try_group(Pending(target, source, relative, covariance, score, inliers, rmse))
            return rejected
        self.slam.refresh_poses()
        self._last_closure_path = self.slam.path[source]
        closure = Closure(source, target, relative, score, inliers, rmse, True, "accepted")
        self._activate(k, closure, covariance)
        return self._record(closure)

    def _try_group(self, new: Pending) -> None:
        """Keep a closure the graph rejected; once enough pending closures agree pairwise, add them together
        (`slam.loop_groups`). If they fit, the graph gave way. If not, the group may name one wide front-end
        match that took the wrong peak (`slam.edge_switch`): that edge is moved to its alternative peak and
        the group tried again. Accepted closures the group contradicts are removed only if outvoted."""
        gc, s = self.config.groups, self.slam
        self.flush()
        self.pending.append(new)
        del self.pending[: max(0, len(self.pending) - gc.max_pending)]
        members = [self.pending[m] for m in largest_group(self.pending, len(self.pending) - 1, s.poses, s.path, gc)]
        if len(members) < gc.min_size:
            return
        added, fits, broken = self._add_group(members)
        if len(fits) >= gc.min_size and len(broken) * gc.outvote <= len(fits):
            self._accept(added, fits, broken)  # fits, contradicting at most a few accepted closures
            return
        self._take_out(added)
        held = [(c.target, c.source) for c in self.active.values()]
        for e, d in named_edges(s, self.config.edge_switch, members, held)[: self.config.edge_switch.tries]:
            try:
                switched = switch_edge(s, e, d)
            except IndeterminateGraph:  # the graph was restored without the switch
                continue
            added, fits, broken = self._add_group(members)
            if len(fits) >= gc.min_size and not broken:
                self.switched.append(e)
                self._accept(added, fits, broken)
                return
            self._take_out(added)
            unswitch(s, switched)

    def _add_group(self, members: list[Pending]) -> tuple[dict[int, Pending], dict[int, Pending], list[int]]:
        """Add the closures, optimise: (added, those that fit, accepted closures that no longer fit)."""
        g, lim = self.slam.graph, self.config.residual_chi2
        added = {g.add_between(p.target, p.source, p.relative, p.covariance, self.config.kernel,
                               self.config.kernel_width): p for p in members}
        g.converge(max_steps=50)
        self._sync()
        fits = {k: p for k, p in added.items() if not g.removed(k) and g.chi2(k) <= lim}
        return added, fits, [k for k in self.active if g.chi2(k) > lim]

    def _take_out(self, added: dict[int, Pending]) -> None:
        for k in added:
            self.slam.graph.remove(k)
        self.slam.graph.converge(max_steps=50)
        self.slam.refresh_poses()

    def _accept(self, added: dict[int, Pending], fits: dict[int, Pending], broken: list[int]) -> None:
        g, s = self.slam.graph, self.slam
        for k in set(added) - set(fits):
            g.remove(k)
        for k in broken:  # accepted closures the group outvotes
            c = self.active[k]
            g.remove(k)
            self._deactivate(k)
            self._record(Closure(c.source, c.target, c.relative, c.score, c.inliers, c.rmse, False,
                                 "removed_by_group"))
        g.converge(max_steps=50)
        s.refresh_poses()
        for k, p in fits.items():
            if g.removed(k):
                continue
            c = Closure(p.source, p.target, p.relative, p.score, p.inliers, p.rmse, True, "accepted_in_group")
            self._activate(k, c, p.covariance)
            self._record(c)
            self._last_closure_path = max(self._last_closure_path, s.path[p.source])
        taken = {id(p) for p in added.values()}
        self.pending = [p for p in self.pending if id(p) not in taken]

    def flush(self) -> None:
        """Optimise the deferred closures (`slam.loop_batch`) and remove any that is still inconsistent."""
        if not self.deferred:
            return
        self.slam.graph.converge(max_steps=20)
        self._check_deferred()
        self.slam.refresh_poses()

    def _check_deferred(self) -> None:
        """After optimising: the deferred closures that failed (GTSAM) or stay inconsistent are taken out."""
        g, deferred = self.slam.graph, self.deferred
        if not deferred:
            return
        self.deferred, self._deferred_since = [], math.inf
        self._sync()
        bad = [k for k in deferred if k in self.active and g.chi2(k) > self.config.residual_chi2]
        for k in bad:
            c = self.active[k]
            g.remove(k)
            self._deactivate(k)
            self._record(Closure(c.source, c.target, c.relative, c.score, c.inliers, c.rmse, False,
                                 "inconsistent_after_optimisation"))
        if bad:
            g.converge(max_steps=20)

    def _sync(self) -> None:
        """Take out of `active` (and record) accepted closures a failed GTSAM step dropped."""
        for k in [k for k in self.active if self.slam.graph.removed(k)]:
            c = self.active[k]
            self._deactivate(k)
            self._record(Closure(c.source, c.target, c.relative, c.score, c.inliers, c.rmse, False,
                                 "graph_indeterminate"))

    def _activate(self, k: int, closure: Closure, covariance: np.ndarray) -> None:
        self.active[k] = closure
        self._edge[k] = (closure.target, closure.source, closure.relative, covariance)
        self.slam.edges.append(self._edge[k])  # for graph.g2o

    def _deactivate(self, k: int) -> None:
        del self.active[k]
        edge = self._edge.pop(k)
        self.slam.edges[:] = [e for e in self.slam.edges if e is not edge]

    def kernel_for(self, target: int, source: int, relative: se2.PoseTuple) -> Kernel:
        """The configured kernel, or Cauchy for a closure that moves the estimate by more than
        `strong_kernel_beyond`: most closures only tidy up centimetres and Huber lets them, while a large
        correction is either a real loop (the rest of the graph then agrees and Cauchy barely matters) or a
        wrong match that only its own factor supports (Cauchy's weight falls off as 1/r², Huber's as 1/r)."""
        c = self.config
        if c.strong_kernel_beyond is None:
            return c.kernel
        now = se2_between(self.slam.poses[target], self.slam.poses[source])
        off = math.hypot(now[0] - relative[0], now[1] - relative[1])
        return "cauchy" if off > c.strong_kernel_beyond else c.kernel

    def _record(self, closure: Closure) -> Closure:
        self.history.append(closure)
        self.reasons[closure.reason] += 1
        return closure

