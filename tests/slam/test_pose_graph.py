"""A square pose graph with one loop closure closes to the closed-form least-squares answer."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam.loop_closure import LoopCloser
from slam.pose_graph import PoseGraph

SIGMA_XY, SIGMA_YAW = 0.05, 1e-6  # headings pinned, so the translation problem is linear


def _square(side_odo: float, side_loop: float) -> tuple[PoseGraph, int]:
    """Odometry says each side is `side_odo` long with exact 90° turns; the loop closure 3 → 0 says
    `side_loop`. Initial guesses are deliberately off."""
    g = PoseGraph(prior_sigmas=(1e-6, 1e-6, 1e-8))
    cov = np.diag([SIGMA_XY**2, SIGMA_XY**2, SIGMA_YAW**2])
    g.add_pose((0.0, 0.0, 0.0))
    guesses = [(1.3, 0.2, 1.4), (1.0, 1.3, 3.0), (-0.2, 1.2, -1.4)]
    for guess in guesses:
        g.add_pose(guess, (side_odo, 0.0, math.pi / 2), cov)
    k = g.add_between(3, 0, (side_loop, 0.0, math.pi / 2), cov, kernel="none")
    return g, k


def _closed_form(side_odo: float, side_loop: float) -> np.ndarray:
    """Headings fixed at 0, 90°, 180°, 270°: world displacements d_k, loop misclosure m = Σ d_k, and the
    least-squares fix subtracts m/4 from each displacement."""
    d = np.array([[side_odo, 0.0], [0.0, side_odo], [-side_odo, 0.0], [0.0, -side_loop]])
    d -= d.sum(axis=0) / 4
    xy = np.vstack([[0.0, 0.0], np.cumsum(d[:3], axis=0)])
    return np.column_stack([xy, [0.0, math.pi / 2, math.pi, -math.pi / 2]])


@pytest.mark.parametrize("optimizer", ["isam2", "batch"])
def test_square_with_one_loop_closure_matches_closed_form(optimizer: str) -> None:
    g, _ = _square(1.1, 1.0)
    g.update()
    g.converge(max_steps=20, tolerance=1e-10)
    if optimizer == "batch":
        g.batch_optimize()
    est = g.poses()
    expected = _closed_form(1.1, 1.0)
    np.testing.assert_allclose(est[:, :2], expected[:, :2], atol=1e-5)
    yaw_err = np.angle(np.exp(1j * (est[:, 2] - expected[:, 2])))
    np.testing.assert_allclose(yaw_err, 0.0, atol=1e-5)
    # the closed form itself: p1 = (1.1, -0.025), p2 = (1.1, 1.05), p3 = (0, 1.025)
    np.testing.assert_allclose(expected[1:, :2], [[1.1, -0.025], [1.1, 1.05], [0.0, 1.025]], atol=1e-12)


def test_consistent_square_closes_exactly_and_leaves_no_residual() -> None:
    g, k = _square(1.0, 1.0)
    g.update()
    g.converge(max_steps=20, tolerance=1e-10)
    np.testing.assert_allclose(g.poses()[:, :2], [[0, 0], [1, 0], [1, 1], [0, 1]], atol=1e-6)
    assert g.chi2(k) < 1e-8


def test_relative_covariance_grows_along_an_open_chain() -> None:
    g = PoseGraph()
    cov = np.diag([0.01**2, 0.01**2, 0.001**2])
    g.add_pose((0.0, 0.0, 0.0))
    for i in range(1, 6):
        g.add_pose((float(i), 0.0, 0.0), (1.0, 0.0, 0.0), cov)
    g.update()
    # five independent steps straight ahead: the x variance adds up exactly
    assert g.relative_covariance(0, 5)[0, 0] == pytest.approx(5 * 0.01**2, rel=1e-6)
    assert g.relative_covariance(0, 5)[1, 1] > g.relative_covariance(0, 2)[1, 1]


def test_gross_false_closure_is_rejected_by_the_gate() -> None:
    g = PoseGraph()
    cov = np.diag([0.01**2, 0.01**2, 0.001**2])
    g.add_pose((0.0, 0.0, 0.0))
    for i in range(1, 20):
        g.add_pose((float(i), 0.0, 0.0), (1.0, 0.0, 0.0), cov)
    g.update()
    closer = LoopCloser()
    bad = closer.add(g, 0, 19, (19.0, 3.0, 0.0), cov)  # claims pose 19 is 3 m to the side
    assert not bad.accepted and bad.reason == "mahalanobis_gate"
    good = closer.add(g, 0, 19, (19.01, 0.0, 0.0), cov)
    assert good.accepted
    assert (closer.accepted, closer.rejected) == (1, 1)
    g.converge(max_steps=20, tolerance=1e-12)
    # fusion of the chain (variance 19σ²) and the closure (σ²): x = 19 + 0.01 · 19/20 (the Cauchy kernel
    # at 0.05σ and the 1 mm prior on pose 0 change that by < 1e-5 m)
    assert g.pose(19)[0] == pytest.approx(19.0095, abs=1e-5)
