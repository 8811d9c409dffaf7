"""planning: occupancy grids and costmaps, exact collision checks, global planners, trajectories.

Part A (maps and global planning) is exported here; the navigation layer (controllers, navigator, ...)
adds its names below.
"""

from planning.collision import FclWorld
from planning.costmap import LayeredCostmap
from planning.global_planners import GridPlanner, OmplPlanner, get_planner, planner_names, register_planner
from planning.grid import OccupancyGrid
from planning.map_io import load_map, save_map
from planning.rasterize import rasterize_world
from planning.render import render_map, save_png
from planning.trajectory import round_corners, shortcut, smooth_path, time_parameterize
from planning.types import (
    FREE,
    INSCRIBED,
    LETHAL,
    UNKNOWN,
    Costmap,
    GlobalPlanner,
    PlanResult,
    Trajectory,
)

__all__ = [
    "FREE", "INSCRIBED", "LETHAL", "UNKNOWN",
    "Costmap", "FclWorld", "GlobalPlanner", "GridPlanner", "LayeredCostmap", "OccupancyGrid", "OmplPlanner",
    "PlanResult", "Trajectory",
    "get_planner", "load_map", "planner_names", "rasterize_world", "register_planner", "render_map",
    "round_corners", "save_map", "save_png", "shortcut", "smooth_path", "time_parameterize",
]
