"""ATE/RPE against closed forms, map IoU, and merging two robots' maps."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planning.grid import OccupancyGrid
from sim.types import Pose2D
from slam import se2
from slam.merge import merge_maps, relative_pose
from slam.metrics import align_se2, map_iou, trajectory_errors
from tests.slam import synth


def _truth(n: int = 200) -> np.ndarray:
    return np.array([p.as_tuple() for p in synth.loop_path(n, 0.1)])


def test_ate_is_zero_for_a_rigidly_moved_trajectory() -> None:
    truth = _truth()
    moved = se2.compose_many(np.tile((3.0, -2.0, 0.7), (len(truth), 1)), truth)
    e = trajectory_errors(moved, truth)
    assert e.ate_rmse < 1e-9 and e.rpe_trans_rmse < 1e-9 and e.rpe_rot_rmse < 1e-9
    inv = se2.from_matrix(np.linalg.inv(se2.to_matrix((3.0, -2.0, 0.7))))
    np.testing.assert_allclose(e.alignment, inv, atol=1e-9)
    assert trajectory_errors(moved, truth, align=False).ate_rmse > 1.0


def test_ate_of_a_constant_offset_across_track() -> None:
    """Points shifted by ±d alternately cannot be aligned away: ATE = d exactly (centroid unchanged)."""
    truth = _truth()
    est = truth.copy()
    est[:, 1] += np.where(np.arange(len(est)) % 2 == 0, 0.05, -0.05)
    assert trajectory_errors(est, truth).ate_rmse == pytest.approx(0.05, rel=0.05)


def test_rpe_of_a_constant_scale_error() -> None:
    """A 1 % scale error in a straight line: every 10-step window (1 m) is 1 cm too long."""
    n = 100
    truth = np.column_stack([np.arange(n) * 0.1, np.zeros(n), np.zeros(n)])
    est = truth * np.array([1.01, 1.0, 1.0])
    e = trajectory_errors(est, truth, rpe_delta=10)
    assert e.rpe_trans_rmse == pytest.approx(0.01, rel=1e-9) and e.rpe_rot_rmse == 0.0


def test_align_se2_recovers_rotation_and_translation() -> None:
    rng = np.random.default_rng(0)
    pts = rng.uniform(-5, 5, (50, 2))
    t = (1.0, 2.0, -0.4)
    x, y, yaw = align_se2(pts, se2.transform_points(t, pts))
    assert (x, y, yaw) == pytest.approx(t, abs=1e-12)


def _room_grid(origin: tuple[float, float] = (-1.025, -1.025)) -> OccupancyGrid:
    return synth.ground_truth_grid(synth.room(), 0.05, (*origin, 21.025, 15.025))


def test_map_iou_identity_and_shift() -> None:
    g = _room_grid()
    same = map_iou(g, g, tolerance_cells=0)
    assert same.occupied == pytest.approx(1.0) and same.free == pytest.approx(1.0)
    shifted = OccupancyGrid(g.data, g.resolution, (g.origin[0] + 0.05, g.origin[1]))
    assert map_iou(shifted, g, tolerance_cells=1).occupied == pytest.approx(1.0, abs=0.02)
    assert map_iou(shifted, g, tolerance_cells=0).occupied < 0.7


def test_merge_two_halves_seen_from_different_frames() -> None:
    """Split the room map, express the right half in a frame rotated by 90° and moved, merge back."""
    g = _room_grid()
    half = g.width // 2
    left = OccupancyGrid(g.data[:, :half].copy(), g.resolution, g.origin)
    right_data = g.data[:, half:].copy()
    # Frame B sits at the right half's lower-left corner, turned +90°. A world cell (r, c) of that half
    # has x_B = (r + ½)·res, y_B = −(c + ½)·res, so in B's grid (origin (0, −W·res)) it is cell
    # (W − 1 − c, r): the array rotated a quarter turn.
    b_in_world = Pose2D(g.origin[0] + half * g.resolution, g.origin[1], math.pi / 2)
    w = right_data.shape[1]
    right_b = OccupancyGrid(np.ascontiguousarray(np.rot90(right_data, k=1)), g.resolution, (0.0, -w * g.resolution))
    merged = merge_maps([(left, Pose2D(0.0, 0.0, 0.0)), (right_b, b_in_world)])
    iou = map_iou(merged, g, tolerance_cells=0)
    assert iou.occupied > 0.98 and iou.free > 0.99
    # a wrong relative pose shows
    bad = merge_maps([(left, Pose2D()), (right_b, Pose2D(b_in_world.x + 0.3, b_in_world.y, b_in_world.yaw))])
    assert map_iou(bad, g, tolerance_cells=1).occupied < 0.9


def test_relative_pose_of_two_map_frames() -> None:
    a, b = Pose2D(1.0, 2.0, 0.5), Pose2D(-3.0, 4.0, -1.0)
    rel = relative_pose(a, b)
    back = se2.from_matrix(se2.to_matrix(a.as_tuple()) @ se2.to_matrix(rel.as_tuple()))
    assert back == pytest.approx(b.as_tuple(), abs=1e-12)
