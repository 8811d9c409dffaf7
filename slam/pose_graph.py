"""GTSAM Pose2 pose graph: odometry and loop-closure between factors, iSAM2 with a batch LM option.

Keys are keyframe indices. Every factor ever added is also kept in `_factors` so a batch
Levenberg-Marquardt re-optimisation (and a rebuild of iSAM2 from its result) sees exactly the graph
iSAM2 has, minus the factors removed by the consistency check.

An iSAM2 step can fail (GTSAM's IndeterminateLinearSystemException, a RuntimeError): a factor with NaN or
near-zero variance, or one that leaves a pose unconstrained. iSAM2 is then unusable (every later step fails
too), so the graph is rebuilt from the last good estimate without the step's culprits: a new pose's edge
that is degenerate on its own is replaced by a loose edge at its guess, and if that is not enough the step's
other new factors (loop closures) are dropped. `dropped` says which factor went and why, `repairs` what
each failed step did.
"""

from __future__ import annotations

from typing import Literal

import gtsam
import numpy as np

from sim.errors import ErrorCode, FleetError
from slam import se2

Kernel = Literal["cauchy", "huber", "none"]


class IndeterminateGraph(FleetError):
    """A graph change GTSAM could not solve; the graph was restored without it."""

    def __init__(self, message: str) -> None:
        super().__init__(ErrorCode.INVALID_ARGUMENT, message, "the change was undone; the graph is as before")


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
                 relinearize_threshold: float = 0.001,
                 loose_sigmas: tuple[float, float, float] = (0.2, 0.2, 0.1)) -> None:
        self._prior = gtsam.noiseModel.Diagonal.Sigmas(np.array(prior_sigmas, dtype=np.float64))
        self._loose = gtsam.noiseModel.Diagonal.Sigmas(np.array(loose_sigmas, dtype=np.float64))
        self._relin = relinearize_threshold
        self._isam = self._new_isam()
        self._factors: list[gtsam.NonlinearFactor | None] = []  # index = iSAM2 factor index (None: removed)
        self._estimate = gtsam.Values()
        self._pending = gtsam.NonlinearFactorGraph()
        self._pending_values = gtsam.Values()
        self._queued: list[tuple[int, bool]] = []  # (factor index, holds a new pose) in _pending
        self._recent: list[int] = []  # other factors of the last update (suspects if relinearising fails)
        self._poses: np.ndarray | None = None  # cache of poses(), dropped whenever the estimate changes
        self.size = 0
        self.chain: dict[int, int] = {}  # pose i → index of the factor from pose i − 1 (its front-end edge)
        self.dropped: dict[int, str] = {}  # factor index → why a failed step dropped it
        self.repairs: list[str] = []  # what each failed step did

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
            self.chain[i] = self._queue(factor, True)
        elif i == 0:
            self._queue(gtsam.PriorFactorPose2(0, gtsam.Pose2(*guess), self._prior), True)
        else:
            if odometry is None or covariance is None:
                raise FleetError(ErrorCode.INVALID_ARGUMENT, "poses after the first need odometry and covariance")
            self.chain[i] = self._queue(gtsam.BetweenFactorPose2(i - 1, i, gtsam.Pose2(*odometry),
                                                                 gaussian(covariance)), True)
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
        """Replace a factor: (the new one's index, the old factor, to swap back later). Raises
        IndeterminateGraph, with the old factor kept, if GTSAM cannot solve the graph with the new one."""
        old = self._factors[factor_index]
        if old is None:
            raise FleetError(ErrorCode.NOT_FOUND, f"factor {factor_index} was removed")
        self.update()  # flush the queue: iSAM2 numbers factors in the order they arrive
        graph = gtsam.NonlinearFactorGraph()
        graph.add(factor)
        self._factors.append(factor)
        new = len(self._factors) - 1
        try:
            self._isam.update(graph, gtsam.Values(), [factor_index])  # in one step: the chain never breaks
        except RuntimeError as e:
            self._factors[new] = None
            self.dropped[new] = _why(e)
            self._restore(self._estimate, f"swap of factor {factor_index} undone: {_why(e)}")
            raise IndeterminateGraph(f"swapping factor {factor_index}: {_why(e)}") from e
        self._factors[factor_index] = None
        self._set_estimate()
        return new, old

    def _queue(self, factor: gtsam.NonlinearFactor, new_pose: bool = False) -> int:
        self._pending.add(factor)
        self._factors.append(factor)
        self._queued.append((len(self._factors) - 1, new_pose))
        return len(self._factors) - 1

    # ---- optimising ----------------------------------------------------------------------------------

    def update(self) -> None:
        """One iSAM2 step with everything queued. If GTSAM fails, the graph is repaired (`_repair`)."""
        graph, values, queued = self._pending, self._pending_values, self._queued
        self._pending, self._pending_values, self._queued = gtsam.NonlinearFactorGraph(), gtsam.Values(), []
        if queued:
            self._recent = [k for k, new_pose in queued if not new_pose]
        try:
            self._isam.update(graph, values)
        except RuntimeError as e:
            self._repair(queued, values, _why(e))
        self._set_estimate()

    def converge(self, max_steps: int = 10, tolerance: float = 1e-4) -> int:
        """Repeat iSAM2 steps until no pose moves more than `tolerance` (after a loop closure, one
        relinearisation is not enough). Returns the number of steps taken."""
        self.update()
        before = self.poses()
        for k in range(1, max_steps + 1):
            try:
                self._isam.update()
            except RuntimeError as e:  # relinearising failed: the last update's other factors are the suspects
                self._repair([(f, False) for f in self._recent], gtsam.Values(), _why(e))
            self._set_estimate()
            after = self.poses()
            if np.abs(after - before).max() < tolerance:
                return k
            before = after
        return max_steps

    def remove(self, factor_index: int) -> None:
        """Drop a factor (a loop closure that failed the consistency check); a no-op if it is gone already."""
        if self._factors[factor_index] is None:
            return
        if self._queued:  # flush the queue first: a rebuild below must see only what iSAM2 has
            self.update()
        self._factors[factor_index] = None
        try:
            self._isam.update(gtsam.NonlinearFactorGraph(), gtsam.Values(), [factor_index])
        except RuntimeError as e:
            self._restore(self._estimate, f"removing factor {factor_index} failed, rebuilt: {_why(e)}")
        self._set_estimate()

    def removed(self, factor_index: int) -> bool:
        return self._factors[factor_index] is None

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
        try:
            result = gtsam.LevenbergMarquardtOptimizer(graph, self._estimate, params).optimize()
            self._rebuild(result)
        except RuntimeError as e:  # keep iSAM2 as it was (`_rebuild` swaps it in only once it succeeded)
            self.repairs.append(f"batch optimisation failed, iSAM2's estimate kept: {_why(e)}")
        self._set_estimate()
        return float(graph.error(self._estimate))

    # ---- recovering from a failed step ---------------------------------------------------------------

    def _rebuild(self, values: gtsam.Values) -> None:
        """A new iSAM2 from every factor at `values`, in the same order, so indices (used by `remove`) stay
        valid: a removed factor's slot holds a placeholder that is removed again at once."""
        isam = self._new_isam()
        rebuilt = gtsam.NonlinearFactorGraph()
        for f in self._factors:
            rebuilt.add(f if f is not None else gtsam.PriorFactorPose2(0, gtsam.Pose2(), self._prior))
        isam.update(rebuilt, values)
        removed = [k for k, f in enumerate(self._factors) if f is None]
        if removed:
            isam.update(gtsam.NonlinearFactorGraph(), gtsam.Values(), removed)
        self._isam = isam

    def _restore(self, values: gtsam.Values, note: str) -> None:
        """Rebuild after a failed step whose culprit is already out of `_factors`."""
        self.repairs.append(note)
        try:
            self._rebuild(values)
        except RuntimeError as e:
            raise FleetError(ErrorCode.INTERNAL, f"pose graph cannot be rebuilt: {_why(e)}",
                             "a factor already in the graph is degenerate") from e

    def _repair(self, step: list[tuple[int, bool]], values: gtsam.Values, why: str) -> None:
        """iSAM2 failed on a step that added `step`'s factors ((index, holds a new pose)) and `values`' poses;
        it is unusable now. Rebuild from the last good estimate: first with every new pose's edge that is
        degenerate on its own replaced by a loose edge at its guess (the pose stays in the chain); if that
        still fails, also without the step's other factors (loop closures), which are dropped."""
        base = gtsam.Values(self._estimate)
        base.insert(values)
        replaced = False
        for k, new_pose in step:
            f = self._factors[k]
            if new_pose and k > 0 and f is not None and not determinate(f, base):
                i, j = sorted(f.keys())
                self._factors[k] = gtsam.BetweenFactorPose2(i, j, base.atPose2(i).between(base.atPose2(j)),
                                                            self._loose)
                self.repairs.append(f"edge {i}->{j} degenerate ({why}): replaced by a loose edge at its guess")
                replaced = True
        if replaced:
            try:
                self._rebuild(base)
                return
            except RuntimeError:
                pass
        others = [k for k, new_pose in step if not new_pose and self._factors[k] is not None]
        for k in others:
            self._factors[k] = None
            self.dropped[k] = why
        self._restore(base, f"step failed ({why}): dropped factors {others}")

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


def _why(error: Exception) -> str:
    text = " ".join(str(error).split())
    return "indeterminate linear system" if "Indeterminate" in text else text[:120]


def determinate(factor: gtsam.NonlinearFactor, values: gtsam.Values) -> bool:
    """Whether a factor pins its newest pose relative to the others on its own at `values`: finite, and the
    information block of that pose positive definite (not near zero relative to its largest eigenvalue)."""
    keys = list(factor.keys())
    info = np.asarray(factor.linearize(values).information())
    if not np.all(np.isfinite(info)):
        return False
    at = 3 * keys.index(max(keys))
    block = info[at:at + 3, at:at + 3]
    eig = np.linalg.eigvalsh(0.5 * (block + block.T))
    return bool(eig.min() > 1e-12 * max(float(eig.max()), 1.0))
