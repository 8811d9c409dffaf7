"""Footprint-exact planning, growing maps, unknown space and sensor-built navigation (issue 13)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from planning.collision import FclWorld
from planning.nav_types import NavState
from planning.navfn import FieldParams, NavField, plan_path
from planning.obstacle_map import ObstacleMap
from planning.rect_footprint import RectFootprint
from planning.sensor_nav import SensorNavConfig, SensorNavigator
from sim import Pose2D, World
from sim.errors import ErrorCode, FleetError
from sim.robot_spec import load_robot_spec
from sim.sdf_writer import save_sdf
from sim.types import WorldDescription
from tests.planning.worlds import box

ROOT = Path(__file__).resolve().parents[2]
JACKAL = load_robot_spec(ROOT / "configs" / "robots" / "barn_jackal.yaml")
FP = RectFootprint(0.508, 0.430)


def test_rectangle_distance_closed_forms():
    pts = np.array([[1.0, 0.0], [0.0, 1.0]])
    # at the origin facing +x: the front face is 0.254 from the centre, the side 0.215
    assert FP.distances([[0.0, 0.0, 0.0]], pts[:1])[0] == pytest.approx(1.0 - 0.254)
    assert FP.distances([[0.0, 0.0, 0.0]], pts[1:])[0] == pytest.approx(1.0 - 0.215)
    # turned by 90°: the roles swap; a corner point: the Euclidean distance to the corner
    assert FP.distances([[0.0, 0.0, math.pi / 2]], pts[1:])[0] == pytest.approx(1.0 - 0.254)
    assert FP.distances([[0.0, 0.0, 0.0]], np.array([[1.254, 1.215]]))[0] == pytest.approx(math.sqrt(2.0))
    assert FP.distances([[0.0, 0.0, 0.0]], np.array([[0.1, 0.1]]))[0] == 0.0  # inside
    assert FP.circumscribed == pytest.approx(math.hypot(0.254, 0.215))


def _corridor_map(gap: float) -> ObstacleMap:
    """A room 6 × 10 m split at y ∈ [1, 3] by a thick wall with one straight corridor of width `gap`
    centred on x = 0.025 (walls sampled every 5 mm, exact lines)."""
    cx, step = 0.025, 0.005
    pts = []
    for y in np.arange(1.0, 3.0 + 1e-9, step):  # corridor walls
        pts += [(cx - gap / 2, y), (cx + gap / 2, y)]
    for x in np.arange(-3.0, 3.0 + 1e-9, step):  # room walls, and the divider's faces outside the corridor
        pts += [(x, -3.0), (x, 7.0)]
        if abs(x - cx) >= gap / 2:
            pts += [(x, 1.0), (x, 3.0)]
    for y in np.arange(-3.0, 7.0 + 1e-9, step):
        pts += [(-3.0, y), (3.0, y)]
    m = ObstacleMap((-3.5, -3.5, 3.5, 7.5))
    m.add_points(np.array(pts))
    m.seen[:] = True
    return m


def test_corridor_exactly_footprint_plus_margin_is_passed():
    margin = 0.05
    m = _corridor_map(0.430 + 2 * margin)
    path, clearance = plan_path(m, Pose2D(0.025, -1.0, math.pi / 2), Pose2D(0.025, 5.0, 0.0), FP,
                                FieldParams(margin=margin))
    assert clearance == pytest.approx(margin, abs=1e-9)  # it took the corridor, exactly margin from both walls
    assert path[0] == pytest.approx([0.025, -1.0]) and path[-1] == pytest.approx([0.025, 5.0])


def test_corridor_one_cm_narrower_is_refused_naming_footprint_and_margin():
    margin = 0.05
    m = _corridor_map(0.430 + 2 * margin - 0.01)
    with pytest.raises(FleetError) as err:
        plan_path(m, Pose2D(0.025, -1.0, math.pi / 2), Pose2D(0.025, 5.0, 0.0), FP, FieldParams(margin=margin))
    assert err.value.code is ErrorCode.PLANNING_FAILED
    assert "footprint 0.508 × 0.430 m" in err.value.message and "safety margin 0.050 m" in err.value.message


def test_unknown_space_optimistic_or_pessimistic():
    m = ObstacleMap((-1.0, -1.0, 6.0, 1.0))  # nothing seen yet
    goal = Pose2D(5.0, 0.0, 0.0)
    assert NavField(m, goal, FP, FieldParams(unknown="optimistic")).reachable(0.0, 0.0)
    assert not NavField(m, goal, FP, FieldParams(unknown="pessimistic")).reachable(0.0, 0.0)


def test_map_grows_to_cover_far_points_and_keeps_them():
    m = ObstacleMap((0.0, 0.0, 1.0, 1.0))
    m.add_points(np.array([[25.0, -12.0]]))
    x0, y0, x1, y1 = m.bounds
    assert x0 <= 0.0 and y0 <= -13.0 and x1 >= 26.0 and y1 >= 1.0
    assert m.clearance_at(np.array([[25.0, -11.0]]))[0] == pytest.approx(1.0)


def _world(tmp_path: Path, models: list, name: str) -> World:
    desc = WorldDescription(name, models=tuple(models))
    save_sdf(desc, tmp_path / f"{name}.world")
    return World.from_sdf(tmp_path / f"{name}.world", fidelity="kinematic", physics_hz=50.0)


def _drive(world: World, nav: SensorNavigator, limit_s: float) -> tuple[bool, float]:
    collided, clearance = False, math.inf
    fcl_world = FclWorld(world.description)
    while not nav.state.done and world.time < limit_s:
        pose = world.robot_pose("r1")
        world.set_cmd_vel("r1", *nav.tick(world.time, pose, world.robot_twist("r1"), world.latest_scan("r1")))
        for _ in range(5):
            world.step(1)
            collided |= world.robot_in_collision("r1")
        clearance = min(clearance, fcl_world.min_distance(world.robot_pose("r1"), JACKAL.footprint))
    return collided, clearance


def test_goal_30_m_outside_the_obstacle_field_is_reached(tmp_path):
    field = [box(f"b{i}", 1.5 + 1.2 * (i % 3), -1.0 + 1.0 * (i // 3), 0.3, 0.3, h=0.6) for i in range(9)]
    world = _world(tmp_path, field, "field")
    start, goal = Pose2D(0.0, 0.0, 0.0), Pose2D(34.0, 2.0, 0.0)  # the field spans x ≤ 4.1: goal 30 m beyond
    world.spawn_robot("r1", start, JACKAL)
    world.run_for(0.2)
    nav = SensorNavigator(SensorNavConfig(resolution=0.1), JACKAL, control_dt=0.1)
    nav.set_goal(goal, world.time, start)
    collided, clearance = _drive(world, nav, 60.0)
    assert nav.state is NavState.SUCCEEDED, nav.status().reason
    assert world.robot_pose("r1").distance_to(goal) <= nav.cfg.goal_tolerance + 0.05
    assert not collided and clearance > 0.0
    world.close()


@pytest.mark.parametrize("source", ["sensors", "both"])
def test_obstacle_absent_from_the_prior_map_is_avoided(tmp_path, source):
    known = [box("wall_w", -1.5, 3.0, 0.2, 8.0), box("wall_e", 1.5, 3.0, 0.2, 8.0)]
    surprise = box("crate", 0.0, 3.0, 1.2, 0.6)  # in the prior map's free corridor, right on the straight line
    world = _world(tmp_path, [*known, surprise], f"surprise_{source}")
    prior = WorldDescription("prior", models=tuple(known))
    start, goal = Pose2D(0.0, 0.0, math.pi / 2), Pose2D(0.0, 6.0, 0.0)
    world.spawn_robot("r1", start, JACKAL)
    world.run_for(0.2)
    nav = SensorNavigator(SensorNavConfig(map_source=source), JACKAL, control_dt=0.1, prior=prior)
    nav.set_goal(goal, world.time, start)
    collided, clearance = _drive(world, nav, 40.0)
    assert nav.state is NavState.SUCCEEDED, nav.status().reason
    assert not collided and clearance > 0.0
    world.close()
