"""PNG rendering draws what it is given; the planner registry refuses duplicates and lists names."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from planning.costmap import LayeredCostmap
from planning.global_planners import GridPlanner, get_planner, planner_names, register_planner
from planning.grid import OccupancyGrid
from planning.render import PATH_COLOURS, render_map, save_png
from sim.errors import ErrorCode, FleetError
from sim.types import Pose2D


def test_render_shows_obstacles_paths_and_goal(tmp_path) -> None:
    grid = OccupancyGrid.empty((0, 0, 4, 3), 0.1)
    grid.data[5, 30] = 100  # the cell at x ∈ [3.0, 3.1], y ∈ [0.5, 0.6]
    cm = LayeredCostmap(grid, robot_radius=0.2)
    img = render_map(cm, robots=[("r1", Pose2D(1, 1, 0))], paths=[np.array([[0.5, 2.5], [3.5, 2.5]])],
                     goals=[Pose2D(3.5, 2.5)], scale=4)
    assert img.size == (40 * 4, 30 * 4)
    px = img.getpixel
    assert px((30 * 4 + 2, (30 - 5 - 1) * 4 + 2)) == (0, 0, 0)  # obstacle, image row 0 = top of the map
    assert px((2 * 40, int((3.0 - 2.5) * 40))) == PATH_COLOURS[0]  # on the path at x = 2 m
    assert px((2 * 40, int((3.0 - 1.5) * 40))) == (255, 255, 255)  # free space
    out = save_png(img, tmp_path / "map.png")
    assert Image.open(out).size == img.size


def test_registry_rejects_duplicates_and_lists_valid_names() -> None:
    with pytest.raises(FleetError) as err:
        register_planner("astar", GridPlanner)
    assert "already registered" in err.value.message
    with pytest.raises(FleetError) as err:
        get_planner("dijkstra")
    assert err.value.code == ErrorCode.INVALID_ARGUMENT
    assert all(name in err.value.hint for name in planner_names())
    with pytest.raises(FleetError) as err:
        get_planner("rrt_connect", time_budget=1.0)  # the option is time_budget_s
    assert "time_budget" in err.value.message
