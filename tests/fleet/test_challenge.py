"""Challenge files, generated arenas, and grading fleetnav's own navigators (batch mode, no Zenoh)."""

from __future__ import annotations

import json
import math

import pytest
import yaml

from fleet.executors import make_executor
from fleet.grading import barn_score, load_challenge, resolve, run_challenge
from fleet.grading.arenas import candidates, difficulty_index, generate, measure
from fleet.grading.challenge import CHALLENGES
from fleet.grading.leaderboard import add, load, markdown
from sim.errors import ErrorCode, FleetError
from sim.worldgen import cluttered_arena

SHIPPED = sorted(CHALLENGES.glob("*.yaml"))


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_shipped_challenges_load_and_resolve(path, tmp_path):
    rc = resolve(load_challenge(path), tmp_path)
    assert rc.world_path.is_file()
    assert rc.start.distance_to(rc.goal) > rc.challenge.success_radius


def test_course_arena_challenge_goes_from_the_spawn_point_to_the_goal_marker(tmp_path):
    rc = resolve(load_challenge("arena_course"), tmp_path)
    assert rc.world_path.name == "robot_arena.world"
    assert rc.start.as_tuple() == (-5.0, -5.0, 0.0)
    assert (rc.goal.x, rc.goal.y) == (5.0, 5.0)


def test_a_typo_names_the_file_line_and_field(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: bad\nworld: robot_arena\nstart: spawn_start\ngoal: goal_marker\ntime_limit: 10\n"
                   "succes_radius: 0.5\n", encoding="utf-8")
    with pytest.raises(FleetError) as err:
        load_challenge(bad)
    assert err.value.code is ErrorCode.INVALID_CONFIG
    assert f"{bad}:6" in err.value.message and "succes_radius" in err.value.message


def test_world_and_arena_are_exclusive_and_names_must_exist(tmp_path):
    both = tmp_path / "both.yaml"
    both.write_text("name: both\nworld: robot_arena\narena: {seed: 1, difficulty: 1}\nstart: spawn_start\n"
                    "goal: goal_marker\ntime_limit: 10\n", encoding="utf-8")
    with pytest.raises(FleetError, match="exactly one of world or arena"):
        load_challenge(both)
    unknown = tmp_path / "unknown.yaml"
    unknown.write_text("name: unknown\nworld: robot_arena\nstart: spawn_nowhere\ngoal: goal_marker\ntime_limit: 10\n",
                       encoding="utf-8")
    with pytest.raises(FleetError, match="spawn_start"):  # the error lists what is known
        resolve(load_challenge(unknown), tmp_path)


def test_generated_set_is_ranked_by_difficulty_and_reproducible():
    pool = candidates(levels=(1, 3, 5), per_level=3)
    infos = generate(count=3, pool=pool)
    index = [difficulty_index(i) for i in infos]
    assert index == sorted(index)
    for i in infos:
        again = measure(cluttered_arena(i.seed, i.difficulty, i.size), seed=i.seed, difficulty=i.difficulty,
                        size=i.size)
        assert again == i
        assert i.tortuosity >= 1.0 - 1e-9 and i.optimal_length >= i.straight_distance - 1e-9


def test_shipped_arena_challenges_match_their_generator():
    for path in sorted(CHALLENGES.glob("cluttered_*.yaml")):
        doc = yaml.safe_load(path.read_text(encoding="utf-8"))
        a = doc["arena"]
        info = measure(cluttered_arena(a["seed"], a["difficulty"], a["size"]), seed=a["seed"],
                       difficulty=a["difficulty"], size=a["size"])
        assert doc["time_limit"] == info.time_limit


def test_builtin_navigator_is_graded_with_the_exact_barn_score(tmp_path):
    report = run_challenge("cluttered_1", controller="builtin:pure_pursuit", runs=1, out_dir=tmp_path)
    run = report.runs[0]
    assert run.outcome.value == "succeeded", run.reason
    s = run.score
    # cluttered_1's optimal path is the free diagonal from (-4, -4) to (4, 4), at the diffbot's 1 m/s
    assert s.optimal_length == pytest.approx(8 * math.sqrt(2), abs=0.02)
    assert s.t_opt == pytest.approx(s.optimal_length / 1.0)
    assert s.score == pytest.approx(s.t_opt / min(max(s.time, 2 * s.t_opt), 8 * s.t_opt))
    assert s.score == barn_score(True, s.time, s.t_opt)
    assert 0.125 <= s.score <= 0.5
    # reached within the success radius: T is the first tick inside it
    inside = [r[0] for r in run.trajectory if math.hypot(r[1] - 4.0, r[2] - 4.0) <= 0.5]
    assert s.time == pytest.approx(inside[0])
    assert s.collisions == 0 and s.min_clearance > 0.0
    doc = json.loads(report.files["json"].read_text(encoding="utf-8"))
    assert doc["runs"][0]["score"] == pytest.approx(s.score)
    assert "data:image/png;base64," in report.files["html"].read_text(encoding="utf-8")
    assert report.files["png"].stat().st_size > 1000
    assert (tmp_path / "challenge.yaml").is_file() and (tmp_path / "run_0.csv").is_file()
    board = tmp_path / "leaderboard.json"
    add(board, report, "pure pursuit")
    add(board, report, "pure pursuit")  # the same contestant again replaces its entry
    assert [e["contestant"] for e in load(board)] == ["pure pursuit"]
    assert "pure pursuit" in markdown(load(board))


def test_unknown_builtin_lists_the_valid_ones(tmp_path):
    with pytest.raises(FleetError, match="builtin:mpc_osqp"):
        run_challenge("cluttered_1", controller="builtin:teleport", out_dir=tmp_path)


def test_same_challenge_and_seed_give_the_same_trajectory(tmp_path):
    a = run_challenge("cluttered_5", controller="builtin:mpc_osqp", runs=1, out_dir=tmp_path / "a")
    b = run_challenge("cluttered_5", controller="builtin:mpc_osqp", runs=1, out_dir=tmp_path / "b")
    assert a.runs[0].trajectory.shape == b.runs[0].trajectory.shape
    assert (a.runs[0].trajectory == b.runs[0].trajectory).all()
    assert a.runs[0].score == b.runs[0].score


def test_map_source_reaches_a_builtin_and_sensors_only_still_passes_an_arena(tmp_path):
    """`map_source` (default sensors) goes to a builtin's navigator; on `sensors` (its own lidar only, unknown
    space traversable) the navigator solves a generated arena; a bad value names the field."""
    from fleet.grading.runner import navigation_settings

    sensed = load_challenge("cluttered_1")
    assert sensed.map_source == "sensors"
    assert navigation_settings(sensed, "builtin:mpc_osqp") == {"controller": {"type": "mpc_osqp"},
                                                                "map_source": "sensors"}
    assert navigation_settings(sensed, "python my_nav.py") == {}  # an agent brings its own navigation
    report = run_challenge(sensed, controller="builtin:mpc_osqp", runs=1, out_dir=tmp_path / "out")
    assert report.runs[0].score.success, report.runs[0].reason
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: bad\nworld: robot_arena\nstart: spawn_start\ngoal: goal_marker\ntime_limit: 10\n"
                   "map_source: lidar\n", encoding="utf-8")
    with pytest.raises(FleetError, match="map_source"):
        load_challenge(bad)


def test_a_live_challenge_run_serves_the_map_to_a_viewer(tmp_path):
    import threading
    import time

    from fleet.grading.runner import LiveSettings
    from tests.fleet.ws_viewer import Viewer
    from tests.fleet.zenoh_util import free_port

    port = free_port()
    got: dict[str, object] = {}

    def watch() -> None:
        deadline = time.monotonic() + 20.0
        while time.monotonic() < deadline and "map" not in got:
            try:
                viewer = Viewer("127.0.0.1", port)
            except OSError:
                time.sleep(0.05)
                continue
            try:
                while "/map" not in viewer.channels and time.monotonic() < deadline:
                    viewer.pump(time.monotonic() + 0.2)
                viewer.subscribe("/map")
                got["map"] = viewer.wait_for("/map")
            finally:
                viewer.close()

    t = threading.Thread(target=watch, daemon=True)
    t.start()
    known = load_challenge("cluttered_1").model_copy(update={"map_source": "prior"})  # on sensors: no /map
    report = run_challenge(known, controller="builtin:pure_pursuit", runs=1, out_dir=tmp_path,
                           live=LiveSettings(port, speed=20.0))
    t.join(timeout=1.0)
    run = report.runs[0]
    assert run.outcome.value == "succeeded"
    assert got.get("map"), "the live viewer got no /map"
    with pytest.raises(FleetError, match="live view"):
        run_challenge("cluttered_1", controller="builtin:pure_pursuit", runs=1, out_dir=tmp_path / "b",
                      live=LiveSettings(port), executor=make_executor("local", jobs=2))
