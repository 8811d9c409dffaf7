"""planning: maps, costmaps, exact collision checks, global planners, trajectories (part A) and the
navigation layer: controllers, reactive safety, recovery, navigator, waypoints, coverage (part B).

Importing the package registers the built-in planners and controllers, so lookup by `type:` never
depends on import order.
"""

from planning.collision import FclWorld
from planning.controllers import (
    CasadiMpc,
    CasadiMpcConfig,
    Controller,
    ControllerConfig,
    OsqpMpc,
    OsqpMpcConfig,
    PathReference,
    PurePursuitConfig,
    RegulatedPurePursuit,
    controller_names,
    make_controller,
    register_controller,
)
from planning.controllers.recovery import Recovery, RecoveryConfig
from planning.costmap import LayeredCostmap
from planning.coverage import coverage_stats, plan_coverage
from planning.global_planners import GridPlanner, OmplPlanner, get_planner, planner_names, register_planner
from planning.grid import OccupancyGrid
from planning.map_io import load_map, save_map
from planning.nav_types import (
    ControlOutput,
    CoveragePlan,
    NavState,
    NavStatus,
    SafetyResult,
    SafetyState,
    Waypoint,
    WaypointStatus,
    WaypointVisit,
)
from planning.navigator import Navigator, NavigatorConfig, Route, make_navigator
from planning.rasterize import rasterize_world
from planning.reactive import NoSafety, ReactiveConfig, ReactiveLayer, make_reactive
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
from planning.waypoints import WaypointFollower, WaypointMode, visit_order

__all__ = [
    "FREE",
    "INSCRIBED",
    "LETHAL",
    "UNKNOWN",
    "CasadiMpc",
    "CasadiMpcConfig",
    "ControlOutput",
    "Controller",
    "ControllerConfig",
    "Costmap",
    "CoveragePlan",
    "FclWorld",
    "GlobalPlanner",
    "GridPlanner",
    "LayeredCostmap",
    "NavState",
    "NavStatus",
    "Navigator",
    "NavigatorConfig",
    "NoSafety",
    "OccupancyGrid",
    "OmplPlanner",
    "OsqpMpc",
    "OsqpMpcConfig",
    "PathReference",
    "PlanResult",
    "PurePursuitConfig",
    "ReactiveConfig",
    "ReactiveLayer",
    "Recovery",
    "RecoveryConfig",
    "RegulatedPurePursuit",
    "Route",
    "SafetyResult",
    "SafetyState",
    "Trajectory",
    "Waypoint",
    "WaypointFollower",
    "WaypointMode",
    "WaypointStatus",
    "WaypointVisit",
    "controller_names",
    "coverage_stats",
    "get_planner",
    "load_map",
    "make_controller",
    "make_navigator",
    "make_reactive",
    "plan_coverage",
    "planner_names",
    "rasterize_world",
    "register_controller",
    "register_planner",
    "render_map",
    "round_corners",
    "save_map",
    "save_png",
    "shortcut",
    "smooth_path",
    "time_parameterize",
    "visit_order",
]
