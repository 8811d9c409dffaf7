"""On `map_source: sensors` (the graded default) a builtin explores a maze it cannot see: optimistic planning
through unknown space sends it towards the goal into the dead end below the second barrier, and it still
reaches the goal — the walls it found stay in its map, and exploring (a route that keeps growing) is not taken
for being stuck. (Before, a 'no progress' recovery wiped the scans' map and the robot went back into the same
dead ends until the time limit: this run timed out 3.2 m from the goal.)"""

from __future__ import annotations

import numpy as np

from fleet.grading import run_challenge
from fleet.grading.challenge import load_challenge
from fleet.paths import CONFIGS
from sim.sdf_primitives import enclosure, ground_plane, marker, sun, wall
from sim.sdf_writer import save_sdf
from sim.types import WorldDescription

H = 5.0  # half side of the walled square, m
GAP = 1.6  # each barrier leaves this much open at one end, m
LIDAR_RANGE = 2.5  # m: short, so the maze is discovered while driving


def _s_maze(path) -> None:
    """Two barriers across a 10 m square: the first open at the east end, the second at the west end."""
    models = (ground_plane(), *enclosure(H, H, 1.0), wall("b1", -H, -H / 3, H - GAP, -H / 3),
              wall("b2", -H + GAP, H / 3, H, H / 3), marker("goal_marker", H - 1, H - 1))
    save_sdf(WorldDescription(name="s_maze", models=models, lights=(sun(),)), path, comment="S-maze test world")


def test_a_builtin_on_sensors_explores_a_maze_out_of_its_dead_end_and_reaches_the_goal(tmp_path):
    _s_maze(tmp_path / "s.world")
    robot = (CONFIGS / "robots" / "diffbot.yaml").read_text(encoding="utf-8")
    robot = robot.replace("name: diffbot", "name: diffbot_short").replace("range_max: 10.0",
                                                                            f"range_max: {LIDAR_RANGE}")
    assert f"range_max: {LIDAR_RANGE}" in robot
    (tmp_path / "short.yaml").write_text(robot, encoding="utf-8")
    (tmp_path / "s.yaml").write_text(
        f"name: s_maze\nworld: s.world\nstart: {{x: {1 - H}, y: {1 - H}, yaw: 0.0}}\ngoal: goal_marker\n"
        "time_limit: 120\nrobot: short.yaml\nruns: 1\n", encoding="utf-8")
    ch = load_challenge(tmp_path / "s.yaml")
    assert ch.map_source == "sensors"  # the graded default: the navigator does not read s.world
    report = run_challenge(ch, controller="builtin:pure_pursuit", out_dir=tmp_path / "out")
    run = report.runs[0]
    assert run.score.success, run.reason
    assert run.score.collisions == 0
    x, y = run.trajectory[:, 1], run.trajectory[:, 2]
    # the optimistic route first led towards the goal, into the dead end under the second barrier's east end …
    assert ((x > 2.0) & (y > 0.0) & (y < H / 3)).any()
    # … and the robot came back west through the second barrier's gap, the only way to the goal
    assert (x[y > H / 3] < -H + GAP).any()
    assert np.hypot(x[-1] - (H - 1), y[-1] - (H - 1)) <= ch.success_radius + 1e-6
