"""Bicubic map cost and the smooth scan-to-map refinement (slam.scan_refine) against closed forms."""

from __future__ import annotations

import math

import numpy as np

from sim.types import Pose2D
from slam.scan_refine import BicubicField, RefineConfig, refine
from tests.slam import synth


def test_bicubic_is_exact_at_samples_and_on_linear_functions() -> None:
    rng = np.random.default_rng(1)
    vals = rng.random((30, 40))
    f = BicubicField(vals, np.array([1.0, -2.0]), 0.1)
    centres = np.array([[1.0 + (c + 0.5) * 0.1, -2.0 + (r + 0.5) * 0.1] for r, c in [(7, 5), (20, 33), (2, 2)]])
    assert np.allclose(f.evaluate(centres)[0], [vals[7, 5], vals[20, 33], vals[2, 2]], atol=1e-12)
    rows, cols = np.mgrid[0:30, 0:40]
    lin = BicubicField(0.3 * cols + 0.7 * rows, np.zeros(2), 0.1)  # Catmull-Rom reproduces linear data
    q = np.column_stack([rng.uniform(0.3, 3.5, 50), rng.uniform(0.3, 2.5, 50)])
    v, g = lin.evaluate(q)
    assert np.allclose(v, 0.3 * (q[:, 0] / 0.1 - 0.5) + 0.7 * (q[:, 1] / 0.1 - 0.5), atol=1e-9)
    assert np.allclose(g, [[3.0, 7.0]] * 50, atol=1e-9)  # per metre


def test_bicubic_gradient_matches_finite_differences() -> None:
    rng = np.random.default_rng(2)
    f = BicubicField(rng.random((30, 40)), np.array([1.0, -2.0]), 0.1)
    p = np.column_stack([rng.uniform(1.3, 4.5, 200), rng.uniform(-1.7, 0.6, 200)])
    _, g = f.evaluate(p)
    ex, ey = np.array([1e-6, 0.0]), np.array([0.0, 1e-6])
    gx = (f.evaluate(p + ex)[0] - f.evaluate(p - ex)[0]) / 2e-6
    gy = (f.evaluate(p + ey)[0] - f.evaluate(p - ey)[0]) / 2e-6
    assert np.abs(gx - g[:, 0]).max() < 1e-6 and np.abs(gy - g[:, 1]).max() < 1e-6


def _field(segs: np.ndarray, res: float = 0.05, sigma: float = 0.07) -> BicubicField:
    """exp(−d²/2σ²) of the exact distance d to the room's walls, sampled at the cell centres."""
    xs, ys = np.arange(-1.0, 21.0, res) + res / 2, np.arange(-1.0, 15.0, res) + res / 2
    px, py = np.meshgrid(xs, ys)
    p = np.column_stack([px.ravel(), py.ravel()])
    d = np.full(len(p), np.inf)
    for x0, y0, x1, y1 in segs:
        a, e = np.array([x0, y0]), np.array([x1 - x0, y1 - y0])
        t = np.clip((p - a) @ e / (e @ e), 0.0, 1.0)
        d = np.minimum(d, np.hypot(*(p - a - t[:, None] * e).T))
    return BicubicField(np.exp(-0.5 * (d / sigma) ** 2).reshape(px.shape), np.array([-1.0, -1.0]), res)


def test_refinement_recovers_a_sub_cell_offset_and_a_small_rotation() -> None:
    segs = synth.room()
    field = _field(segs)
    truth = Pose2D(8.03, 4.41, 0.3)
    scan = synth.raycast(segs, truth, beams=360).points()
    cfg = RefineConfig(translation_weight=0.0, rotation_weight=0.0)
    for off in [(0.03, -0.02, math.radians(0.5)), (-0.04, 0.015, math.radians(-0.7)), (0.02, 0.02, 0.0)]:
        start = (truth.x + off[0], truth.y + off[1], truth.yaw + off[2])
        res = refine(field, scan, start, cfg)
        assert res.converged
        assert math.hypot(res.pose[0] - truth.x, res.pose[1] - truth.y) < 0.003, (off, res.pose)
        assert abs(res.pose[2] - truth.yaw) < math.radians(0.03), (off, res.pose)
        assert res.score > 0.97


def test_prior_weights_pull_towards_the_prior_in_proportion() -> None:
    """With a flat map (all cells equal) only the prior terms act: the result is the prior."""
    field = BicubicField(np.full((50, 50), 0.5), np.zeros(2), 0.1)
    pts = np.array([[1.0, 0.0], [0.0, 1.0], [1.5, 1.0]])
    res = refine(field, pts, (2.0, 2.0, 0.1), RefineConfig(translation_weight=1.0, rotation_weight=1.0),
                 prior=(2.5, 1.8, -0.05))
    assert np.allclose(res.pose, (2.5, 1.8, -0.05), atol=1e-6)
