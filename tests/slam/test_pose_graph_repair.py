"""A GTSAM step that cannot be solved (IndeterminateLinearSystemException) does not end the run: the pose graph
drops the closure that caused it, or replaces a degenerate edge by a loose one, and keeps going with the
least-squares answer of the graph that remains."""

from __future__ import annotations

import math

import gtsam
import numpy as np
import pytest

from slam.pose_graph import IndeterminateGraph, PoseGraph

PRIOR = (1e-3, 1e-3, 1e-8)
COV = np.diag([0.01**2, 0.01**2, 1e-12])  # headings pinned: the translation problem is linear


def _chain(n: int) -> PoseGraph:
    """Poses 0 … n − 1 one metre apart along x, odometry exact."""
    g = PoseGraph(prior_sigmas=PRIOR)
    g.add_pose((0.0, 0.0, 0.0))
    for i in range(1, n):
        g.add_pose((float(i), 0.0, 0.0), (1.0, 0.0, 0.0), COV)
    return g


@pytest.mark.parametrize("relative, covariance", [
    ((math.nan, 0.0, 0.0), COV),  # a NaN measurement
    ((4.0, 0.3, 0.0), np.diag([1e-30, 0.01**2, 1e-12])),  # a variance no Cholesky pivot survives
])
def test_closure_that_makes_the_graph_indeterminate_is_dropped(relative: tuple[float, float, float],
                                                               covariance: np.ndarray) -> None:
    g = _chain(5)
    g.update()
    with pytest.raises(RuntimeError, match="Indeterminate"):  # what GTSAM does with it on its own
        isam = gtsam.ISAM2()
        graph = gtsam.NonlinearFactorGraph()
        graph.add(gtsam.BetweenFactorPose2(0, 4, gtsam.Pose2(*relative), gtsam.noiseModel.Gaussian.Covariance(
            covariance)))
        graph.add(gtsam.PriorFactorPose2(0, gtsam.Pose2(), gtsam.noiseModel.Diagonal.Sigmas(np.array(PRIOR))))
        for i in range(4):
            graph.add(gtsam.BetweenFactorPose2(i, i + 1, gtsam.Pose2(1, 0, 0),
                                               gtsam.noiseModel.Gaussian.Covariance(COV)))
        values = gtsam.Values()
        for i in range(5):
            values.insert(i, gtsam.Pose2(float(i), 0.0, 0.0))
        isam.update(graph, values)
    g.add_pose((5.0, 0.0, 0.0), (1.0, 0.0, 0.0), COV)  # a pose queued in the same step survives it
    k = g.add_between(0, 4, relative, covariance, kernel="none")
    g.converge(max_steps=20, tolerance=1e-10)
    assert g.removed(k) and "indeterminate" in g.dropped[k]
    np.testing.assert_allclose(g.poses()[:, :2], [[i, 0.0] for i in range(6)], atol=1e-9)
    # … and the graph still works: a consistent closure 0 → 5 with a 0.1 m sideways offset is added
    ok = g.add_between(0, 5, (5.0, 0.1, 0.0), COV, kernel="none")
    g.converge(max_steps=20, tolerance=1e-10)
    assert not g.removed(ok)
    y = g.poses()[:, 1]
    np.testing.assert_allclose(y, _sideways_closure(5, 0.1), atol=1e-6)
    assert np.all(np.diff(y) > 0)  # the offset is spread along the chain


def _sideways_closure(n: int, offset: float) -> np.ndarray:
    """Closed form of y0 … yn: y0 has the prior (σ 1e-3), y_i − y_{i−1} = 0 (σ 0.01), and the closure
    yn − y0 = offset (σ 0.01); headings pinned, so it is linear least squares."""
    eye = np.eye(n + 1)
    rows = [eye[0] / PRIOR[0]] + [(eye[i] - eye[i - 1]) / 0.01 for i in range(1, n + 1)] + [(eye[n] - eye[0]) / 0.01]
    rhs = np.zeros(n + 2)
    rhs[-1] = offset / 0.01
    return np.linalg.lstsq(np.array(rows), rhs, rcond=None)[0]


def test_pose_held_only_by_a_zero_information_edge_gets_a_loose_edge() -> None:
    g = _chain(3)
    dead = gtsam.BetweenFactorPose2(2, 3, gtsam.Pose2(1.0, 0.0, 0.0), gtsam.noiseModel.Diagonal.Precisions(np.zeros(3)))
    g.add_pose((3.2, 0.3, 0.1), factor=dead)  # nothing else holds pose 3
    k = g.add_between(0, 2, (2.0, 0.05, 0.0), COV, kernel="none")  # a good closure in the same step
    g.converge(max_steps=20, tolerance=1e-10)
    assert not g.removed(k) and any("2->3" in r and "loose edge" in r for r in g.repairs)
    est = g.poses()
    # pose 3 keeps its guess relative to pose 2's guess; pose 2 moved half-way to the closure's 0.05 (y1 too)
    y = _sideways_closure(2, 0.05)
    np.testing.assert_allclose(est[:3, 1], y, atol=1e-6)
    np.testing.assert_allclose(est[3], [3.2, 0.3 + y[2], 0.1], atol=1e-6)


def test_swap_that_makes_the_graph_indeterminate_is_undone() -> None:
    g = _chain(4)
    g.update()
    before = g.poses().copy()
    dead = gtsam.BetweenFactorPose2(2, 3, gtsam.Pose2(1.0, 0.0, 0.0), gtsam.noiseModel.Diagonal.Precisions(np.zeros(3)))
    with pytest.raises(IndeterminateGraph):
        g.swap(g.chain[3], dead)
    assert not g.removed(g.chain[3])
    g.add_pose((4.0, 0.0, 0.0), (1.0, 0.0, 0.0), COV)
    g.converge(tolerance=1e-10)
    np.testing.assert_allclose(g.poses()[:4], before, atol=1e-9)
    assert g.poses()[4, 0] == pytest.approx(4.0, abs=1e-9)
