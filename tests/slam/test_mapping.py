"""Log-odds mapping against exact geometry, and map save → load round-trips exactly."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from planning.grid import OccupancyGrid
from planning.map_io import load_map, save_map
from sim.errors import FleetError
from sim.types import Pose2D
from slam.mapping import OccupancyMapper
from slam.metrics import map_iou
from tests.slam import synth

SEGS = synth.room()
# Ground truth offset by half a cell so the room's walls (at whole metres) run through cell centres.
TRUTH = synth.ground_truth_grid(SEGS, 0.05, (-1.025, -1.025, 21.025, 15.025))


def _map_from_poses(poses: list[Pose2D], resolution: float = 0.05) -> OccupancyMapper:
    m = OccupancyMapper(resolution=resolution)
    rng = np.random.default_rng(0)
    for p in poses:
        scan = synth.raycast(SEGS, p, noise=0.01, rng=rng)
        no_ret = scan.angles()[~np.isfinite(scan.ranges)]
        m.integrate(p.as_tuple(), scan.points(), no_ret)
    return m


def test_log_odds_follow_the_update_counts() -> None:
    """Hit +0.85, miss −0.4; occupied above logit(0.65) = 0.62, free below logit(0.196) = −1.41:
    one scan makes the end cell occupied; the cells the beam passes need four scans to become free."""
    m = OccupancyMapper(resolution=0.1)
    beam = np.array([[2.0, 0.0]])
    passed = [(x, 0.05) for x in np.arange(0.15, 1.8, 0.1)]
    for scans in range(1, 5):
        m.integrate((0.05, 0.05, 0.0), beam)
        g = m.grid(crop=False)
        assert g.data[g.world_to_cell(2.05, 0.05)] == 100
        assert {int(g.data[g.world_to_cell(x, y)]) for x, y in passed} == ({0} if scans == 4 else {-1})
    assert m.log_odds.max() == pytest.approx(3.4)  # 4 × 0.85, below the 3.5 clamp
    assert g.data[g.world_to_cell(0.05, 1.05)] == -1  # never observed


def test_mapping_from_true_poses_matches_the_geometry() -> None:
    poses = synth.loop_path(400, 0.12)[::4]
    grid = _map_from_poses(poses).grid()
    iou = map_iou(grid, TRUTH, tolerance_cells=1)
    assert iou.occupied > 0.9 and iou.free > 0.95
    shifted = OccupancyGrid(grid.data, grid.resolution, (grid.origin[0] + 0.3, grid.origin[1]))
    assert map_iou(shifted, TRUTH, tolerance_cells=1).occupied < 0.5  # a 30 cm error is visible


def test_map_save_load_round_trips_exactly(tmp_path: Path) -> None:
    grid = _map_from_poses(synth.loop_path(200, 0.2)[::5]).grid()
    assert set(np.unique(grid.data)) <= {-1, 0, 100}
    path = save_map(grid, tmp_path / "room.yaml")
    back = load_map(path)
    assert back.resolution == grid.resolution and back.origin == grid.origin
    assert back.data.dtype == np.int8 and np.array_equal(back.data, grid.data)
    assert (tmp_path / "room.pgm").read_bytes()[:2] == b"P5"


def test_empty_mapper_has_no_map() -> None:
    with pytest.raises(FleetError) as e:
        OccupancyMapper().grid()
    assert e.value.code == "NOT_FOUND"
