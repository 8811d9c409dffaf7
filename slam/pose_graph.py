"""GTSAM Pose2 pose graph: odometry and loop-closure between factors, iSAM2 with a batch LM option.

Keys are keyframe indices. Every factor ever added is also kept in `_factors` so a batch
Levenberg-Marquardt re-optimisation (and a rebuild of iSAM2 from its result) sees exactly the graph
iSAM2 has, minus the factors removed by the consistency check.
"""

from __future__ import annotations

from typing import Literal

import gtsam
import numpy as np

from sim.errors import ErrorCode, FleetError
from slam import se2

Kernel = Literal["cauchy", "huber", "none"]


def gaussian(covariance: np.ndarray) -> gtsam.noiseModel.Base:
    return gtsam.noiseModel.Gaussian.Covariance(np.asarray(covariance, dtype=np.float64))


def robust(base: gtsam.noiseModel.Base, kernel: Kernel, width: float) -> gtsam.noiseModel.Base:
    if kernel == "none":
        return base
    est = gtsam.noiseModel.mEstimator
    m = est.Cauchy.Create(width) if kernel == "cauchy" else est.Huber.Create(width)
    return gtsam.noiseModel.Robust.Create(m, base)


class PoseGraph:
    def __init__(self, *, prior_sigmas: tuple[float, float, float] = (1e-3, 1e-3, 1e-4),
                 relinearize_threshold: float = 0.001) -> None:
        self._prior = gtsam.noiseModel.Diagonal.Sigmas(np.array(prior_sigmas, dtype=np.float64))
        self._relin = relinearize_threshold
        self._isam = self._new_isam()
        self._factors: list[gtsam.NonlinearFactor | None] = []  # index = iSAM2 factor index (None: removed)
        self._estimate = gtsam.Values()
        self._pending = gtsam.NonlinearFactorGraph()
        self._pending_values = gtsam.Values()
        self._poses: np.ndarray | None = None  # cache of poses(), dropped whenever the estimate changes
        self.size = 0
        self.chain: dict[int, int] = {}  # pose i → index of the factor from pose i − 1 (its front-end edge)

    def _new_isam(self) -> gtsam.ISAM2:
        params = gtsam.ISAM2Params()
        params.setRelinearizeThreshold(self._relin)
        params.relinearizeSkip = 1
        return gtsam.ISAM2(params)

    # ---- building ------------------------------------------------------------------------------------

    def add_pose(self, guess: se2.PoseTuple, odometry: se2.PoseTuple | None = None,
                 covariance: np.ndarray | None = None, factor: gtsam.NonlinearFactor | None = None) -> int:
        """Add the next pose; the first is anchored by a prior, later ones by an odometry factor (or by
        `factor`, e.g. a max-mixture edge from pose i − 1, instead)."""
        i = self.size
        if factor is not None and i > 0:
            self.chain[i] = self._queue(factor)
        elif i == 0:
            self._queue(gtsam.PriorFactorPose2(0, gtsam.Pose2(*guess), self._prior))
        else:
            if odometry is None or covariance is None:
                raise FleetError(ErrorCode.INVALID_ARGUMENT, "poses after the first need odometry and covariance")
            self.chain[i] = self._queue(gtsam.BetweenFactorPose2(i - 1, i, gtsam.Pose2(*odometry),
                                                                 gaussian(covariance)))
        self._pending_values.insert(i, gtsam.Pose2(*guess))
        self._poses = None
        self.size += 1
        return i

    def add_between(self, i: int, j: int, relative: se2.PoseTuple, covariance: np.ndarray,
                    kernel: Kernel = "cauchy", kernel_width: float = 1.0) -> int:
        """A loop closure (pose j in pose i's frame); returns its factor index."""
        for k in (i, j):
            if not 0 <= k < self.size:
                raise FleetError(ErrorCode.INVALID_ARGUMENT, f"pose {k} is not in the graph (size {self.size})")
        noise = robust(gaussian(covariance), kernel, kernel_width)
        return self._queue(gtsam.BetweenFactorPose2(i, j, gtsam.Pose2(*relative), noise))

    def swap(self, factor_index: int, factor: gtsam.NonlinearFactor) -> tuple[int, gtsam.NonlinearFactor]:
        """Replace a factor: (the new one's index, the old factor, to swap back later)."""
        old = self._factors[factor_index]
        if old is None:
            raise FleetError(ErrorCode.NOT_FOUND, f"factor {factor_index} was removed")
        self.update()  # flush the queue: iSAM2 numbers factors in the order they arrive
        graph = gtsam.NonlinearFactorGraph()
        graph.add(factor)
        self._factors.append(factor)
        self._isam.update(graph, gtsam.Values(), [factor_index])  # in one step: the chain never breaks
        self._factors[factor_index] = None
        self._set_estimate()
        return len(self._factors) - 1, old

    def _queue(self, factor: gtsam.NonlinearFactor) -> int:
        self._pending.add(factor)
        self._factors.append(factor)
        return len(self._factors) - 1

    # ---- optimising ----------------------------------------------------------------------------------

    def update(self) -> None:
        """One iSAM2 step with everything queued."""
        self._isam.update(self._pending, self._pending_values)
        self._pending = gtsam.NonlinearFactorGraph()
        self._pending_values = gtsam.Values()
        self._set_estimate()

    def converge(self, max_steps: int = 10, tolerance: float = 1e-4) -> int:
        """Repeat iSAM2 steps until no pose moves more than `tolerance` (after a loop closure, one
        relinearisation is not enough). Returns the number of steps taken."""
        self.update()
        before = self.poses()
        for k in range(1, max_steps + 1):
            self._isam.update()
            self._set_estimate()
            after = self.poses()
            if np.abs(after - before).max() < tolerance:
                return k
            before = after
        return max_steps

    def remove(self, factor_index: int) -> None:
        """Drop a factor (a loop closure that failed the consistency check)."""
        self._isam.update(gtsam.NonlinearFactorGraph(), gtsam.Values(), [factor_index])
        self._factors[factor_index] = None
        self._set_estimate()

    def batch_optimize(self, max_iterations: int = 100) -> float:
        """Levenberg-Marquardt over the whole graph from the current estimate; iSAM2 restarts from the
        result (factor indices are preserved). Returns the final error."""
        self.update()
        graph = gtsam.NonlinearFactorGraph()
        for f in self._factors:
            if f is not None:
                graph.add(f)
        params = gtsam.LevenbergMarquardtParams()
        params.setMaxIterations(max_iterations)
        result = gtsam.LevenbergMarquardtOptimizer(graph, self._estimate, params).optimize()
        # Rebuild iSAM2 with the same factor order so indices (used by `remove`) stay valid.
        self._isam = self._new_isam()
        rebuilt = gtsam.NonlinearFactorGraph()
        for f in self._factors:
            rebuilt.add(f if f is not None else gtsam.PriorFactorPose2(0, gtsam.Pose2(), self._prior))
        removed = [k for k, f in enumerate(self._factors) if f is None]
        self._isam.update(rebuilt, result)
        if removed:
            self._isam.update(gtsam.NonlinearFactorGraph(), gtsam.Values(), removed)
        self._set_estimate()
        return float(graph.error(self._estimate))

    def _set_estimate(self) -> None:
        self._estimate = self._isam.calculateEstimate()
        self._poses = None

    # ---- reading -------------------------------------------------------------------------------------

    def pose(self, i: int) -> se2.PoseTuple:
        values = self._estimate if self._estimate.exists(i) else self._pending_values
        p = values.atPose2(i)
        return (p.x(), p.y(), p.theta())

    def poses(self) -> np.ndarray:
        """(n, 3) current estimate of every pose (not yet optimised ones at their guess)."""
        if self._poses is None:
            est = gtsam.utilities.extractPose2(self._estimate).reshape(-1, 3)
            pend = gtsam.utilities.extractPose2(self._pending_values).reshape(-1, 3)
            self._poses = np.vstack([est, pend])  # keys are 0..n-1: optimised ones first, then pending
        return self._poses

    def relative_covariance(self, i: int, j: int) -> np.ndarray:
        """Covariance of pose j in pose i's frame, from the joint marginal (correlations included)."""
        keys = gtsam.KeyVector([i, j])
        joint = self._isam.jointMarginalCovariance(keys)
        sii, sjj, sij = joint.at(i, i), joint.at(j, j), joint.at(i, j)
        rel = se2.from_matrix(np.linalg.inv(se2.to_matrix(self.pose(i))) @ se2.to_matrix(self.pose(j)))
        a = -se2.adjoint(se2.from_matrix(np.linalg.inv(se2.to_matrix(rel))))  # ∂(Ti⁻¹Tj)/∂ξi
        return a @ sii @ a.T + sjj + a @ sij + sij.T @ a.T

    def chi2(self, factor_index: int) -> float:
        """Squared Mahalanobis error of a factor at the current estimate, ignoring its robust kernel."""
        f = self._factors[factor_index]
        if f is None:
            raise FleetError(ErrorCode.NOT_FOUND, f"factor {factor_index} was removed")
        assert isinstance(f, gtsam.NoiseModelFactor)  # every factor here is one (between, prior, custom)
        model = f.noiseModel()
        if isinstance(model, gtsam.noiseModel.Robust):
            model = model.noise()
        return float(model.squaredMahalanobisDistance(np.asarray(f.unwhitenedError(self._estimate))))

    def error(self) -> float:
        graph = gtsam.NonlinearFactorGraph()
        for f in self._factors:
            if f is not None:
                graph.add(f)
        return float(graph.error(self._estimate))

