"""Lidar and depth-cloud processing against closed-form scans and a rendered scene with known floor."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.errors import FleetError
from sim.perception import (
    cluster_obstacles,
    depth_to_points,
    fit_ground_plane,
    ground_by_height,
    label_pixels,
    remove_ground,
    sector_minima,
    statistical_outlier_removal,
    voxel_filter,
)
from sim.types import Pose3D
from tests.sim.perception.pb_scene import Scene
from tests.sim.perception.raycast2d import Circle, Rect, scan_from

OBSTACLES: list[Circle | Rect] = [Circle(3.0, 0.0, 0.3), Circle(-2.0, 2.5, 0.5), Circle(0.0, -4.0, 0.25),
                                  Circle(-3.5, -1.0, 0.4), Rect(2.0, 3.0, 1.0, 0.6, 0.4)]


def test_clustering_finds_each_known_obstacle() -> None:
    scan = scan_from(0.0, 0.0, 0.0, OBSTACLES, beams=720, noise=0.01)
    obstacles = cluster_obstacles(scan.points(), eps=0.2, min_points=3)
    assert len(obstacles) == len(OBSTACLES)
    for sh in OBSTACLES:
        size = sh.r if isinstance(sh, Circle) else math.hypot(sh.sx, sh.sy) / 2
        nearest = min(obstacles, key=lambda o: math.hypot(o.centre[0] - sh.x, o.centre[1] - sh.y))
        # The lidar sees the near side: the centroid sits between the surface and the centre.
        assert math.hypot(nearest.centre[0] - sh.x, nearest.centre[1] - sh.y) < size
        assert max(nearest.extent) < 2 * size + 0.05


def test_clustering_respects_min_points() -> None:
    pts = np.array([[0.0, 0.0], [0.05, 0.0], [0.1, 0.0], [5.0, 5.0]])  # a 3-point cluster and a loner
    assert [o.count for o in cluster_obstacles(pts, eps=0.08, min_points=2)] == [3]
    assert sorted(o.count for o in cluster_obstacles(pts, eps=0.08, min_points=1)) == [1, 3]


def test_voxel_filter_keeps_one_centroid_per_voxel() -> None:
    g = (np.arange(40) + 0.5) * 0.05  # a 2 m × 2 m grid of points every 5 cm
    pts = np.array([(x, y) for x in g for y in g])
    out = voxel_filter(pts, 0.2)
    assert len(out) == 100  # (2 m / 0.2 m)²
    centres = np.array([(x, y) for x in (np.arange(10) + 0.5) * 0.2 for y in (np.arange(10) + 0.5) * 0.2])
    assert np.allclose(np.sort(out.view("f8,f8"), axis=0).view(float),
                       np.sort(centres.view("f8,f8"), axis=0).view(float))


def test_statistical_outlier_removal_drops_injected_outliers() -> None:
    rng = np.random.default_rng(3)
    a = np.linspace(0, 2 * np.pi, 500, endpoint=False)
    ring = np.column_stack([2 * np.cos(a), 2 * np.sin(a)]) + rng.normal(0, 0.005, (500, 2))
    outliers = rng.uniform(-1.0, 1.0, (10, 2))  # inside the ring, far from it and from each other
    _, mask = statistical_outlier_removal(np.vstack([ring, outliers]), k=8, std_ratio=2.0)
    assert not mask[500:].any()
    assert mask[:500].mean() > 0.98


def test_sector_minima_in_a_rectangular_room() -> None:
    walls: list[Circle | Rect] = [Rect(2.05, 0, 0.1, 6.2), Rect(-2.05, 0, 0.1, 6.2),
                                  Rect(0, 3.05, 4.2, 0.1), Rect(0, -3.05, 4.2, 0.1)]
    scan = scan_from(0.5, -1.0, 0.0, walls)  # inner faces x = ±2, y = ±3; lidar at (0.5, −1)
    secs = sector_minima(scan, 4)
    # Sectors from −π: [−π, −π/2) sees −x (2.5) and −y (2); [−π/2, 0) sees −y (2) and +x (1.5); ...
    expect = [(2.0, -math.pi / 2), (1.5, 0.0), (1.5, 0.0), (2.5, math.pi)]
    for s, (r, bearing) in zip(secs, expect, strict=True):
        assert s.min_range == pytest.approx(r, rel=1e-3)
        assert abs(math.remainder(s.angle - bearing, 2 * math.pi)) <= math.radians(1.01)
    with pytest.raises(FleetError):
        sector_minima(scan, 0)


def test_ground_removal_on_a_rendered_depth_cloud() -> None:
    s = Scene()
    try:
        s.add_ground()
        s.add_box("a", Pose3D(3.0, 0.5, 0.3), (0.6, 0.6, 0.6))
        s.add_box("b", Pose3D(4.0, -1.0, 0.5), (0.5, 0.5, 1.0))
        image = s.render(Pose3D(0.0, 0.0, 1.0, 0.0, math.radians(15), 0.0), 120, 90)
    finally:
        s.close()
    assert image.segmentation is not None and image.depth is not None
    pts = depth_to_points(image)
    lm = label_pixels(image.segmentation, s.labeler)
    valid = np.isfinite(image.depth) & (image.depth < image.far)
    is_floor = lm.ids[valid] == lm.labels.index(("ground_plane", "link"))
    plane = fit_ground_plane(pts, threshold=0.02, rng=np.random.default_rng(1))
    assert np.degrees(np.arccos(plane.normal[2])) < 0.5 and abs(plane.d) < 0.01  # the floor is z = 0
    assert plane.inliers[is_floor].mean() > 0.99
    assert plane.inliers[~is_floor].mean() < 0.05  # only the boxes' bottom rims touch the floor
    rest = remove_ground(pts, plane, min_height=0.02)
    assert len(rest) == pytest.approx(int((~is_floor).sum()), rel=0.05)
    assert ground_by_height(pts, 0.0, 0.02).inliers[is_floor].mean() > 0.99
