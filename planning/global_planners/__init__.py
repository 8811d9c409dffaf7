"""Global planners: grid A* / Theta* and OMPL's sampling planners, looked up by name in one registry."""

from planning.global_planners.grid_astar import GridPlanner
from planning.global_planners.ompl_planner import ALGORITHMS, OmplPlanner
from planning.global_planners.registry import get_planner, planner_names, register_planner

# Built-ins are registered here, so registration never depends on import order (STYLE.md §5).
register_planner("astar", lambda **kw: GridPlanner(any_angle=False, **kw))
register_planner("theta_star", lambda **kw: GridPlanner(any_angle=True, **kw))
register_planner("guided_theta_star", lambda **kw: GridPlanner(any_angle=True, guided=True, **kw))
for _algo in ALGORITHMS:
    register_planner(_algo, lambda _a=_algo, **kw: OmplPlanner(algorithm=_a, **kw))

__all__ = ["GridPlanner", "OmplPlanner", "get_planner", "planner_names", "register_planner"]
