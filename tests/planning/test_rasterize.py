"""Rasterising known shapes gives the closed-form cells (cells a shape overlaps with positive area)."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest
import shapely

from planning.grid import OccupancyGrid
from planning.rasterize import rasterize_world
from sim.types import Collision, Link, Mesh, ModelDescription, Pose3D, WorldDescription
from tests.planning.worlds import box, cylinder, sphere

RES = 0.05


def _occupied(*models: ModelDescription, bounds=(-3.0, -3.0, 3.0, 3.0)) -> OccupancyGrid:
    return rasterize_world(WorldDescription("t", models=models), resolution=RES, bounds=bounds)


def test_axis_aligned_box_on_cell_edges_covers_exactly_its_cells() -> None:
    grid = _occupied(box("b", 0.5, 0.25, 1.0, 0.5))  # x ∈ [0, 1], y ∈ [0, 0.5]
    occ = grid.occupied()
    assert occ.sum() == (1.0 / RES) * (0.5 / RES)  # 20 × 10 cells, none more
    r0, c0 = grid.world_to_cell(0.001, 0.001)
    assert occ[r0:r0 + 10, c0:c0 + 20].all()


def test_rotated_box_matches_exact_polygon_overlap() -> None:
    yaw, sx, sy, cx, cy = 0.7, 1.3, 0.45, 0.31, -0.42
    grid = _occupied(box("b", cx, cy, sx, sy, yaw=yaw))
    c, s = math.cos(yaw), math.sin(yaw)
    corners = [(cx + c * u - s * v, cy + s * u + c * v) for u, v in
               [(sx / 2, sy / 2), (-sx / 2, sy / 2), (-sx / 2, -sy / 2), (sx / 2, -sy / 2)]]
    poly = shapely.Polygon(corners)
    x, y = grid.cell_centres()
    cells = shapely.box(x - RES / 2, y - RES / 2, x + RES / 2, y + RES / 2)
    expected = shapely.area(shapely.intersection(cells, poly)) > 1e-12
    assert np.array_equal(grid.occupied(), expected)
    # and the count is the box area give or take a one-cell border
    n, area, perimeter = expected.sum(), sx * sy, 2 * (sx + sy)
    assert area / RES**2 <= n <= (area + perimeter * RES * math.sqrt(2) + 2 * math.pi * RES**2) / RES**2


@pytest.mark.parametrize("r", [0.2, 0.5, 0.77])
def test_cylinder_cell_count_is_disc_area_within_one_cell_border(r: float) -> None:
    grid = _occupied(cylinder("c", 0.013, -0.021, r))
    n = grid.occupied().sum()
    border = 2 * math.pi * r * RES * math.sqrt(2) + 2 * math.pi * RES**2
    assert (math.pi * r * r) / RES**2 <= n <= (math.pi * r * r + border) / RES**2
    # every occupied cell overlaps the disc, every cell whose centre is in the disc is occupied
    x, y = grid.cell_centres()
    d = np.hypot(x - 0.013, y + 0.021)
    assert grid.occupied()[d < r].all()
    assert not grid.occupied()[d > r + RES * math.sqrt(2) / 2].any()


def test_slab_keeps_only_obstacles_at_robot_height() -> None:
    low = box("decal", 1, 1, 0.5, 0.5, h=0.01)  # z ∈ [0, 0.01]: under the slab
    high = box("shelf", -1, -1, 0.5, 0.5, h=0.3, z0=1.2)  # z ∈ [1.2, 1.5]: above it
    grid = _occupied(low, high)
    assert grid.occupied().sum() == 0
    # a sphere centred 0.3 m above the slab top reaches into it with a cross-section radius √(0.5² − 0.3²) = 0.4
    grid = _occupied(sphere("ball", 0.0, 0.0, 1.3, 0.5))
    n = grid.occupied().sum()
    r = 0.4
    assert math.pi * r * r / RES**2 <= n <= (math.pi * r * r + 2 * math.pi * r * RES * 1.5) / RES**2


def test_mesh_footprint_is_its_scaled_bounding_box(tmp_path) -> None:
    # binary STL with two triangles spanning x ∈ [-0.5, 0.5], y ∈ [-0.25, 0.25], z ∈ [0, 1]
    tris = [((-0.5, -0.25, 0), (0.5, -0.25, 0), (0.5, 0.25, 1)), ((-0.5, -0.25, 0), (0.5, 0.25, 1), (-0.5, 0.25, 1))]
    data = b"\0" * 80 + struct.pack("<I", len(tris))
    for t in tris:
        data += struct.pack("<12fH", 0, 0, 1, *[c for v in t for c in v], 0)
    path = tmp_path / "block.stl"
    path.write_bytes(data)
    mesh = Mesh(uri="block.stl", path=str(path), scale=(2.0, 1.0, 1.0))
    model = ModelDescription("m", Pose3D(0.5, 0.25, 0), True, (Link("l", collisions=(Collision("c", mesh),)),))
    grid = _occupied(model)
    assert grid.occupied().sum() == (2.0 / RES) * (0.5 / RES)  # 2 × 0.5 m box, x ∈ [-0.5, 1.5], y ∈ [0, 0.5]
    assert grid.occupied()[grid.world_to_cell(-0.49, 0.01)]
    assert not grid.occupied()[grid.world_to_cell(-0.51, 0.01)]
