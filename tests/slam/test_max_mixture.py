"""Max-mixture Pose2 edge (slam/max_mixture.py): error and Jacobians against the closed form and finite
differences, component selection, and a chain whose wrong edge is switched off by agreeing loop closures."""

from __future__ import annotations

import math

import gtsam
import numpy as np

from slam.max_mixture import Component, max_mixture_factor, switchable


def _values(a: tuple[float, float, float], b: tuple[float, float, float]) -> gtsam.Values:
    v = gtsam.Values()
    v.insert(0, gtsam.Pose2(*a))
    v.insert(1, gtsam.Pose2(*b))
    return v


def _between_error(z: tuple[float, float, float], a: tuple[float, float, float],
                   b: tuple[float, float, float]) -> np.ndarray:
    """Closed form: Logmap(z⁻¹ · a⁻¹ · b) of Pose2."""
    rel = gtsam.Pose2(*a).between(gtsam.Pose2(*b))
    return np.asarray(gtsam.Pose2.Logmap(gtsam.Pose2(*z).between(rel)))


def test_error_is_the_best_components_whitened_error_plus_its_constant() -> None:
    c1 = Component((1.0, 0.0, 0.0), np.diag([0.01, 0.04, 0.0025]), 1.0)
    c2 = Component((3.0, 0.0, 0.0), np.diag([0.01, 0.01, 0.01]), 0.1)
    factor, mix = max_mixture_factor(0, 1, [c1, c2])
    a, b = (0.0, 0.0, 0.0), (1.1, 0.05, 0.02)
    v = _values(a, b)
    e1 = _between_error(c1.relative, a, b)
    m1 = float(e1 @ np.linalg.inv(c1.covariance) @ e1)
    e2 = _between_error(c2.relative, a, b)
    m2 = float(e2 @ np.linalg.inv(c2.covariance) @ e2)
    k1 = 0.5 * math.log(np.linalg.det(c1.covariance)) - math.log(1.0)
    k2 = 0.5 * math.log(np.linalg.det(c2.covariance)) - math.log(0.1)
    costs = np.array([0.5 * m1 + k1, 0.5 * m2 + k2])
    assert mix.active(v) == int(np.argmin(costs)) == 0
    # GTSAM's factor error ½‖e‖² = the chosen component's negative log-density minus the smallest constant
    assert math.isclose(factor.error(v), float(costs.min()) - min(k1, k2), rel_tol=1e-9, abs_tol=1e-12)
    # near the second component, it is chosen
    v2 = _values(a, (3.0, 0.1, 0.05))
    assert mix.active(v2) == 1


def test_jacobians_match_finite_differences() -> None:
    comps = [Component((1.0, 0.2, 0.3), np.array([[0.02, 0.005, 0.0], [0.005, 0.03, 0.0], [0.0, 0.0, 0.01]]), 1.0),
             Component((1.0, 0.2, 0.3), np.diag([4.0, 4.0, 1.0]), 1e-3)]
    factor, mix = max_mixture_factor(0, 1, comps)
    for a, b in [((0.3, -0.2, 0.4), (1.1, 0.9, 0.8)), ((0.0, 0.0, 0.0), (4.0, 2.0, 1.5))]:
        v = _values(a, b)
        jac: list[np.ndarray] = [np.zeros((4, 3)), np.zeros((4, 3))]
        e0 = mix.evaluate(factor, v, jac)
        k = mix.active(v)
        eps = 1e-6
        for key, pose in ((0, a), (1, b)):
            num = np.zeros((4, 3))
            for d in range(3):
                delta = np.zeros(3)
                delta[d] = eps
                moved = gtsam.Pose2(*pose).retract(delta)
                p = (moved.x(), moved.y(), moved.theta())
                vv = _values(p, b) if key == 0 else _values(a, p)
                assert mix.active(vv) == k
                num[:, d] = (mix.evaluate(factor, vv, None) - e0) / eps
            np.testing.assert_allclose(jac[key], num, atol=1e-5)
        assert np.all(jac[0][3] == 0) and np.all(jac[1][3] == 0)


def test_agreeing_loops_switch_off_a_wrong_switchable_edge() -> None:
    """A straight chain of 1 m steps where step 3→4 was matched 2 m short (a corridor peak); three loop
    closures from the true geometry pull. With the wrong edge as a switchable max-mixture the optimum is the
    truth; as a plain Gaussian edge the error is spread and stays large."""
    truth = [(float(k), 0.0, 0.0) for k in range(8)]
    tight = np.diag([1e-4, 1e-4, 1e-5])

    def solve(use_mixture: bool) -> float:
        g = gtsam.NonlinearFactorGraph()
        g.add(gtsam.PriorFactorPose2(0, gtsam.Pose2(), gtsam.noiseModel.Diagonal.Sigmas(np.array([1e-3] * 3))))
        init = gtsam.Values()
        x = 0.0
        for k in range(1, 8):
            step = (-1.0, 0.0, 0.0) if k == 4 else (1.0, 0.0, 0.0)
            if k == 4 and use_mixture:
                g.add(max_mixture_factor(3, 4, switchable(step, tight, 2.5, 1.0, 1e-3))[0])
            else:
                noise = gtsam.noiseModel.Gaussian.Covariance(tight)
                g.add(gtsam.BetweenFactorPose2(k - 1, k, gtsam.Pose2(*step), noise))
            x += step[0]
            init.insert(k, gtsam.Pose2(x, 0.0, 0.0))
        init.insert(0, gtsam.Pose2())
        for t, s in ((1, 6), (2, 7), (1, 7)):  # loops measured from the truth
            z = gtsam.Pose2(*truth[t]).between(gtsam.Pose2(*truth[s]))
            g.add(gtsam.BetweenFactorPose2(t, s, z, gtsam.noiseModel.Gaussian.Covariance(np.diag([4e-4, 4e-4, 1e-4]))))
        res = gtsam.LevenbergMarquardtOptimizer(g, init).optimize()
        return max(abs(res.atPose2(k).x() - truth[k][0]) for k in range(8))

    assert solve(True) < 0.02
    assert solve(False) > 0.1
