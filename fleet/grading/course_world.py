"""`fleetnav check world`: grade an SDF world against the course's "Custom Gazebo World" requirements (15 pts).

Judged on geometry, as a grader looking at the world would: obstacles and their shapes are counted per
collision geometry (five obstacles written as links of one model are five), and the maze item asks for
barriers that make the shortest collision-free start→goal path at least 20 % longer than the straight line,
with the goal still reachable, for a robot of the course robot's half-width.
"""

from __future__ import annotations

from pathlib import Path

from fleet.grading.maze import shortest_path
from fleet.grading.rubric import RubricReport
from sim.sdf_conventions import GOAL_PREFIX, is_marker, markers
from sim.sdf_parser import parse_sdf
from sim.types import Box, Collision, Pose2D, WorldDescription

MIN_SIZE = 10.0  # m, each side
MIN_OBSTACLES = 5
MIN_LIGHTS = 2
BARRIER_MIN_LENGTH = 2.0  # m: a wall segment long enough to shape a maze
BARRIER_MAX_THICKNESS = 0.6  # m
MAZE_DETOUR = 1.2  # shortest path / straight line
ROBOT_HALF_WIDTH = 0.2  # m: the course robot's chassis is 0.4 m wide


def _is_barrier(c: Collision) -> bool:
    if not isinstance(c.geometry, Box):
        return False
    sx, sy = sorted(c.geometry.size[:2], reverse=True)
    return sx >= BARRIER_MIN_LENGTH and sy <= BARRIER_MAX_THICKNESS


def check_world(path: str | Path) -> RubricReport:
    desc = parse_sdf(str(path))
    return grade_world(desc, str(path))


def _start_goal(desc: WorldDescription, notes: list[str]) -> tuple[Pose2D, Pose2D]:
    """The first spawn point and the goal marker; where one is missing, the world corner opposite the other."""
    x0, y0, x1, y1 = desc.bounds()
    corners = [Pose2D(x0 + 1, y0 + 1), Pose2D(x1 - 1, y1 - 1), Pose2D(x0 + 1, y1 - 1), Pose2D(x1 - 1, y0 + 1)]

    def opposite(p: Pose2D) -> Pose2D:
        return max(corners, key=lambda c: (c.x - p.x) ** 2 + (c.y - p.y) ** 2)

    goals = markers(desc, GOAL_PREFIX)
    start = desc.spawn_points[0].pose if desc.spawn_points else None
    goal = next(iter(goals.values())) if goals else None
    if start is None:
        start = opposite(goal) if goal is not None else corners[0]
        notes.append(f"maze: no spawn point, so the path starts at ({start.x:.1f}, {start.y:.1f})")
    if goal is None:
        goal = opposite(start)
        notes.append(f"maze: no goal marker ('{GOAL_PREFIX}*' model), so the path ends at ({goal.x:.1f}, {goal.y:.1f})")
    return start, goal


def grade_world(desc: WorldDescription, source: str) -> RubricReport:
    rep = RubricReport(f"Custom Gazebo World ({Path(source).name})", source)
    shapes = [c for m in desc.models if not is_marker(m) for _, c, _ in m.world_collisions()]
    ground = [m for m in desc.models if any(c.geometry.kind == "plane" for _, c, _ in m.world_collisions())]
    solid = [c for c in shapes if c.geometry.kind != "plane"]
    barriers = [c for c in solid if _is_barrier(c)]
    obstacles = [c for c in solid if not _is_barrier(c)]
    variety = {c.geometry.kind for c in obstacles} & {"box", "cylinder", "sphere"}
    xmin, ymin, xmax, ymax = desc.bounds()
    size = (xmax - xmin, ymax - ymin)
    textured = bool(ground) and desc.ground_material is not None
    start, goal = _start_goal(desc, rep.notes)
    path = shortest_path(desc, start, goal, robot_radius=ROBOT_HALF_WIDTH)
    if not path.reachable:
        blocked = "the start" if not path.start_free else "the goal" if not path.goal_free else None
        maze = f"goal unreachable ({blocked} is inside an obstacle)" if blocked else "goal unreachable"
    else:
        maze = f"shortest path {path.shortest:.2f} m vs straight {path.straight:.2f} m (×{path.ratio:.2f})"

    rep.add("sdf_format", "world is valid SDF", 1, True, f"SDF {desc.sdf_version}, parsed", "parses as SDF")
    rep.add("ground_textured", "ground plane with a textured surface", 2, textured,
            f"{len(ground)} ground plane(s), material {desc.ground_material!r}", "a plane with a material/texture")
    rep.add("obstacle_count", f"at least {MIN_OBSTACLES} obstacles", 3, len(obstacles) >= MIN_OBSTACLES,
            f"{len(obstacles)} obstacle collision geometries", f"≥ {MIN_OBSTACLES}")
    rep.add("shape_variety", "obstacles of different shapes (boxes, cylinders, spheres)", 2,
            variety == {"box", "cylinder", "sphere"}, ", ".join(sorted(variety)) or "none",
            "box, cylinder and sphere")
    rep.add("maze", "physical barriers forming a maze or navigation challenge", 3,
            path.reachable and path.ratio >= MAZE_DETOUR - 1e-9, f"{maze}; {len(barriers)} wall segments",
            f"goal reachable by a {2 * ROBOT_HALF_WIDTH:g} m wide robot, path ≥ {MAZE_DETOUR:g} × straight line")
    rep.add("lights", f"at least {MIN_LIGHTS} light sources", 2, len(desc.lights) >= MIN_LIGHTS,
            f"{len(desc.lights)} lights", f"≥ {MIN_LIGHTS}")
    rep.add("size", f"world at least {MIN_SIZE:g} m × {MIN_SIZE:g} m", 1,
            min(size) >= MIN_SIZE - 1e-6, f"{size[0]:.2f} m × {size[1]:.2f} m", f"≥ {MIN_SIZE:g} × {MIN_SIZE:g}")
    rep.add("spawn_point", "a spawn point for the robot", 1, bool(desc.spawn_points),
            ", ".join(s.name for s in desc.spawn_points) or "none", "a frame/model named spawn*")
    if desc.unsupported:
        rep.notes.append(f"elements fleetnav does not simulate: {', '.join(desc.unsupported[:10])}")
    return rep
