"""A scan matched against a known transform of itself recovers it (point-to-line ICP and KISS-ICP)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.transforms import se2_between, se2_compose
from sim.types import Pose2D
from slam import se2
from slam.icp import IcpTarget, icp
from slam.odometry import KissOdometry
from tests.slam import synth

SEGS = synth.room()


@pytest.mark.parametrize("motion", [(0.3, -0.2, 0.15), (-0.25, 0.4, -0.3), (0.05, 0.0, 0.25)])
def test_icp_recovers_a_known_transform_of_the_same_scan(motion: tuple[float, float, float]) -> None:
    target = synth.raycast(SEGS, Pose2D(8.0, 4.0, 0.4)).points()
    # the same points seen from a frame moved by `motion`: source = motion⁻¹ · target
    source = se2.transform_points(se2.from_matrix(np.linalg.inv(se2.to_matrix(motion))), target)
    res = icp(source, IcpTarget.from_points(target), max_correspondence=1.0, tolerance=1e-9)
    assert res.converged and res.inlier_ratio > 0.99
    np.testing.assert_allclose(res.pose[:2], motion[:2], atol=1e-6)
    assert res.pose[2] == pytest.approx(motion[2], abs=1e-7)


def test_icp_recovers_the_motion_between_two_noisy_scans() -> None:
    rng = np.random.default_rng(3)
    a, b = Pose2D(8.0, 4.0, 0.4), Pose2D(8.4, 4.25, 0.55)
    sa = synth.raycast(SEGS, a, noise=0.01, rng=rng).points()
    sb = synth.raycast(SEGS, b, noise=0.01, rng=rng).points()
    truth = se2_between(a.as_tuple(), b.as_tuple())
    res = icp(sb, IcpTarget.from_points(sa), max_correspondence=0.5)
    assert math.hypot(res.pose[0] - truth[0], res.pose[1] - truth[1]) < 0.01
    assert abs(res.pose[2] - truth[2]) < math.radians(0.2)
    assert res.rmse < 0.02  # ≈ the 1 cm range noise


def test_icp_information_is_flat_along_a_corridor() -> None:
    """Two parallel walls: x (along the corridor) is unconstrained by point-to-line, y is stiff."""
    xs = np.linspace(-5, 5, 200)
    pts = np.vstack([np.column_stack([xs, np.full_like(xs, 1.0)]), np.column_stack([xs, np.full_like(xs, -1.0)])])
    res = icp(pts, IcpTarget.from_points(pts))
    info = res.information
    assert info[1, 1] > 1e6 * max(info[0, 0], 1e-12)


def test_kiss_odometry_follows_a_path_with_wheel_guess() -> None:
    rng = np.random.default_rng(4)
    truth = synth.loop_path(150, 0.1)
    wheel = synth.wheel_odometry(truth, rng)
    od = KissOdometry()
    est = (0.0, 0.0, 0.0)
    for k, p in enumerate(truth):
        delta = se2_between(wheel[k - 1].as_tuple(), wheel[k].as_tuple()) if k else None
        est = od.register(synth.raycast(SEGS, p, noise=0.01, rng=rng).points(), delta).pose.as_tuple()
    true_rel = se2_between(truth[0].as_tuple(), truth[-1].as_tuple())
    wheel_rel = se2_between(wheel[0].as_tuple(), wheel[-1].as_tuple())
    err = math.hypot(est[0] - true_rel[0], est[1] - true_rel[1])
    wheel_err = math.hypot(wheel_rel[0] - true_rel[0], wheel_rel[1] - true_rel[1])
    assert err < 0.1 and err < wheel_err / 3  # 15 m with a corner: scan matching beats the wheels
    assert se2_compose(truth[0].as_tuple(), est)[2] == pytest.approx(truth[-1].yaw, abs=math.radians(1.0))
