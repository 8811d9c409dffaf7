"""Hit/miss evidence of the local map (slam.submap_grid): exact counts, exact removal, transients dropped."""

from __future__ import annotations

import numpy as np

from slam.submap_grid import HitMissGrid


def test_one_beam_counts_free_cells_up_to_the_stop_and_a_hit_at_the_end() -> None:
    g = HitMissGrid(0.05, hit=1.0, miss=-1.0)
    g.sync([0], [(0.025, 0.025, 0.0)], [np.array([[1.0, 0.0]])])  # a beam along the row of cell y = 0
    row = np.array([[0.025 + 0.05 * c, 0.025] for c in range(23)])
    lo = g.log_odds(row)
    # samples every 0.035 m stop 1.5 cells (0.075 m) short of the return at x = 1.025: cells 0 … 18 free,
    # cell 19 untouched, cell 20 (the return) hit, nothing beyond
    assert list(lo[:19]) == [-1.0] * 19 and lo[19] == 0.0 and lo[20] == 1.0 and list(lo[21:]) == [0.0, 0.0]


def test_removing_every_scan_leaves_an_empty_grid_and_moved_scans_are_recast() -> None:
    rng = np.random.default_rng(3)
    poses = [(float(x), 0.3 * float(x), 0.1 * float(x)) for x in range(6)]
    scans = [rng.uniform(-8, 8, (150, 2)) for _ in poses]
    g = HitMissGrid(0.05)
    g.sync(range(6), poses, scans)
    assert g.hits.sum() > 0 and g.misses.sum() > 0
    moved = list(poses)
    moved[2] = (2.5, 0.6, 0.2)
    g.sync(range(6), moved, scans)
    assert g.members[2][0] == moved[2]
    ref = HitMissGrid(0.05)
    ref.sync(range(6), moved, scans)
    probe = rng.uniform(-10, 14, (5000, 2))
    assert np.array_equal(g.log_odds(probe), ref.log_odds(probe))  # same as building it from scratch
    g.sync([], moved, scans)
    assert g.hits.sum() == 0 and g.misses.sum() == 0 and not g.members


def test_a_return_that_later_scans_see_through_is_dropped_and_a_wall_is_kept() -> None:
    """Scan 0 sees a person at (3, 0); scans 1–4 see the wall at x = 6 straight through that spot."""
    wall = np.column_stack([np.full(41, 6.0), np.linspace(-1.0, 1.0, 41)])
    person = np.array([[3.0, 0.0]])
    poses = [(0.0, 0.0, 0.0)] * 5
    scans = [np.vstack([wall, person])] + [wall] * 4
    g = HitMissGrid(0.05)
    g.sync(range(5), poses, scans)
    assert g.log_odds(person)[0] == 0.85 - 4 * 0.4  # one hit, four scans through it
    assert np.all(g.log_odds(wall) == 5 * 0.85)  # every scan hit every wall cell
