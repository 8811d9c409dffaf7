"""The navigator drives a robot through the course arena maze to its goal marker in the PyBullet sim, in
both fidelities; collisions are checked by the sim and the clearance by fcl on the world's true shapes."""

from __future__ import annotations

from pathlib import Path

import pytest

from planning.collision import FclWorld
from planning.costmap import LayeredCostmap
from planning.nav_types import NavState
from planning.navigator import NavigatorConfig, make_navigator
from sim import Pose2D, World

ARENA = Path(__file__).resolve().parents[2] / "configs" / "worlds" / "robot_arena.world"
START, GOAL = Pose2D(-5.0, -5.0, 0.0), Pose2D(5.0, 5.0, 0.0)  # spawn_start frame and goal_marker


@pytest.mark.parametrize("fidelity", ["kinematic", "dynamic"])
def test_navigates_the_arena_maze_to_the_goal(fidelity):
    with World.from_sdf(ARENA, fidelity=fidelity, seed=3) as world:
        world.spawn_robot("r1", START)
        spec = world.robot_spec("r1")
        costmap = LayeredCostmap.from_world(world.description, robot_radius=spec.footprint_radius)
        nav = make_navigator(NavigatorConfig(timeout_s=120.0), costmap=costmap, spec=spec)
        fcl_world = FclWorld(world.description)
        nav.set_goal(GOAL, world.time)
        steps = round(0.05 * world.physics_hz)  # a 20 Hz control loop in sim time
        collided, clearance = False, float("inf")
        while not nav.state.done and world.time < 150.0:
            pose = world.robot_pose("r1")
            world.set_cmd_vel("r1", *nav.tick(world.time, pose, world.robot_twist("r1"), world.latest_scan("r1")))
            world.step(steps)
            collided |= world.robot_in_collision("r1")
            clearance = min(clearance, fcl_world.min_distance(world.robot_pose("r1"), spec.footprint))
        st = nav.status()
        assert st.state is NavState.SUCCEEDED, st.reason
        assert world.robot_pose("r1").distance_to(GOAL) <= 0.15
        assert not collided and clearance > 0.05
        # the maze forces a detour: the path is much longer than the straight line (14.1 m)
        assert st.path_length > 1.5 * START.distance_to(GOAL)
        assert st.elapsed_s < 2.0 * st.path_length / spec.limits.max_linear + 10.0
