"""ROS map_server files: save → load round-trips exactly; loading follows the documented thresholds."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from planning.grid import OccupancyGrid
from planning.map_io import load_map, save_map
from sim.errors import ErrorCode, FleetError


def test_save_then_load_round_trips_exactly(tmp_path) -> None:
    rng = np.random.default_rng(5)
    data = rng.choice(np.array([-1, 0, 100], dtype=np.int8), size=(37, 53))
    grid = OccupancyGrid(data, 0.05, (-1.234567, 2.5))
    yaml_path = save_map(grid, tmp_path / "maps" / "arena.yaml")
    back = load_map(yaml_path)
    assert np.array_equal(back.data, grid.data)
    assert back.resolution == grid.resolution and back.origin == grid.origin
    # the image is stored top row first (row 0 of the grid is the bottom of the picture)
    img = np.asarray(Image.open(tmp_path / "maps" / "arena.pgm"))
    assert img.shape == (37, 53)
    assert img[-1, 0] == {-1: 205, 0: 254, 100: 0}[int(data[0, 0])]


def test_trinary_scale_raw_and_negate_follow_map_server(tmp_path) -> None:
    pixels = np.array([[0, 100, 200, 254, 255]], dtype=np.uint8)
    Image.fromarray(pixels, mode="L").save(tmp_path / "m.pgm")

    def load(extra: str) -> np.ndarray:
        (tmp_path / "m.yaml").write_text("image: m.pgm\nresolution: 0.1\norigin: [1.0, 2.0, 0.0]\n"
                                         "occupied_thresh: 0.65\nfree_thresh: 0.25\n" + extra)
        return load_map(tmp_path / "m.yaml").data[0]

    # p = (255 - v) / 255 = [1, 0.608, 0.216, 0.004, 0]
    assert load("negate: 0\n").tolist() == [100, -1, 0, 0, 0]
    # negate: p = v / 255 = [0, 0.392, 0.784, 0.996, 1]
    assert load("negate: 1\n").tolist() == [0, -1, 100, 100, 100]
    # scale: in-between p becomes 100 (p − free) / (occ − free): (0.608 − 0.25) / 0.4 → 89.5 → 90
    p = (255 - 100) / 255
    assert load("mode: scale\n").tolist() == [100, round((p - 0.25) / 0.4 * 100), 0, 0, 0]
    # raw: the value itself, above 100 is unknown
    assert load("mode: raw\n").tolist() == [0, 100, -1, -1, -1]


def test_bad_yaml_field_names_file_and_field(tmp_path) -> None:
    (tmp_path / "m.yaml").write_text("image: m.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nnegat: 1\n")
    with pytest.raises(FleetError) as err:
        load_map(tmp_path / "m.yaml")
    assert err.value.code == ErrorCode.INVALID_CONFIG
    assert "m.yaml:4" in err.value.message and "negat" in err.value.message


def test_missing_image_is_a_clear_error(tmp_path) -> None:
    (tmp_path / "m.yaml").write_text("image: nope.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n")
    with pytest.raises(FleetError) as err:
        load_map(tmp_path / "m.yaml")
    assert err.value.code == ErrorCode.NOT_FOUND and "nope.pgm" in err.value.message
