"""BARN rules and metric by hand on a BARN-format world written here; the `fleetnav barn run` suite."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from fleet.grading.barn import BarnClock, barn_metric, find_pairs, optimal_length, path_to_world
from fleet.grading.barn_run import check_controller
from fleetnav.cli import app
from sim.errors import FleetError
from sim.types import Pose2D

CYLINDER = """    <model name='unit_cylinder_{i}'>
      <static>1</static>
      <pose frame=''>{x:.6f} {y:.6f} 0.000000 0.000000 0.000000 0.000000</pose>
      <link name='link'>
        <collision name='collision'>
          <geometry><cylinder><radius>0.075000</radius><length>1</length></cylinder></geometry>
        </collision>
        <visual name='visual'>
          <geometry><cylinder><radius>0.075000</radius><length>1</length></cylinder></geometry>
        </visual>
      </link>
    </model>
"""


def write_barn_world(d: Path, wid: int) -> list[tuple[int, int]]:
    """A BARN-format pair: two side walls of unit cylinders (columns 0 and 29 of BARN's 0.15 m grid, rows
    0..29, as BARN's x·0.15 − 4.5 + 0.075 layout) and a small block; the path runs up column 15."""
    cells = [(c, r) for r in range(30) for c in (0, 29)] + [(20, 12), (21, 12), (20, 13)]
    body = "".join(CYLINDER.format(i=i, x=c * 0.15 - 4.575 + 0.15, y=r * 0.15 + 5.075)
                   for i, (c, r) in enumerate(cells))
    (d / f"world_{wid}.world").write_text("<sdf version='1.6'>\n  <world name='default'>\n" + body
                                          + "  </world>\n</sdf>\n", encoding="utf-8")
    path = [(15, r) for r in range(30)]
    np.save(d / f"path_{wid}.npy", np.array(path))
    return path


def test_optimal_length_and_metric_by_hand(tmp_path):
    write_barn_world(tmp_path, 7)
    # path cells (15, 0..29) → x = 15·0.15 − 4.575 = −2.325, y from 5.075 to 29·0.15 + 5.075 = 9.425
    assert path_to_world(np.array([[15, 0]]))[0] == pytest.approx([-2.325, 5.075])
    by_hand = math.hypot(0.075, 2.075) + (9.425 - 5.075) + math.hypot(0.075, 13.0 - 9.425)
    assert optimal_length(tmp_path / "path_7.npy") == pytest.approx(by_hand)
    t_opt = by_hand / 2.0
    assert barn_metric(True, 1.0, t_opt) == pytest.approx(0.5)  # faster than 2·T_opt: clipped
    assert barn_metric(True, 3 * t_opt, t_opt) == pytest.approx(1 / 3)
    assert barn_metric(True, 100.0, t_opt) == pytest.approx(0.125)  # slower than 8·T_opt: the floor
    assert barn_metric(False, 3 * t_opt, t_opt) == 0.0


def test_clock_starts_at_0_1_m_and_stops_within_1_m():
    clock = BarnClock()
    for k in range(200):  # 1 m/s straight up from the start, 0.1 s ticks, standing still until 0.55 s
        t = 0.1 * k
        y = 3.0 + max(0.0, t - 0.55)
        if clock.update(t, Pose2D(-2.25, y, 1.57), False):
            break
    # 0.1 m from the start first seen at the 0.7 s tick (0.15 m); within 1 m of (−2.25, 13), y ≥ 12, at 9.6 s
    assert clock.outcome == "succeeded"
    assert clock.t_start == pytest.approx(0.7) and clock.t_end == pytest.approx(9.6)
    assert clock.elapsed == pytest.approx(8.9)
    hit = BarnClock()
    hit.update(0.0, Pose2D(-2.25, 3.5, 1.57), False)
    assert hit.update(0.1, Pose2D(-2.25, 3.6, 1.57), True) == "collided"


def test_bad_inputs_name_what_is_valid(tmp_path):
    write_barn_world(tmp_path, 7)
    with pytest.raises(FleetError) as err:
        find_pairs(tmp_path, [7, 8])
    assert "[8]" in err.value.message and "7" in (err.value.hint or "")
    with pytest.raises(FleetError) as err:
        check_controller("builtin:teleport")
    assert "builtin:footprint_dwa" in (err.value.hint or "")


def test_barn_run_scores_a_hand_written_world(tmp_path):
    path = write_barn_world(tmp_path, 7)
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["barn", "run", "--worlds-dir", str(tmp_path), "--ids", "7", "--robot",
                                   "barn_jackal", "--controller", "builtin:footprint_dwa", "-j", "1",
                                   "--out", str(out)])
    assert res.exit_code == 0, res.output
    rows = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]
    summary = json.loads((out / "summary.json").read_text())
    assert len(rows) == 1 and summary["runs"] == 1
    r = rows[0]
    for key in ("world_id", "success", "collided", "timed_out", "time_s", "distance_to_goal", "path_length",
                "min_clearance", "barn_metric"):
        assert key in r
    assert r["success"] and not r["collided"] and r["distance_to_goal"] <= 1.0
    assert r["lidar_returns_per_scan"] > 0 and not summary["warnings"]  # the Jackal's lidar sees the cylinders
    l_opt = optimal_length(np.array(path))
    assert r["t_opt"] == pytest.approx(l_opt / 2.0, abs=1e-4)
    assert r["barn_metric"] == pytest.approx(r["t_opt"] / min(max(r["time_s"], 2 * r["t_opt"]), 8 * r["t_opt"]),
                                             abs=1e-3)
    assert summary["success_rate"] == 1.0 and summary["mean_barn_metric"] == pytest.approx(r["barn_metric"])


def test_barn_run_on_the_local_pool_matches_one_process(tmp_path):
    """`-j 2` on the local executor (two spawned workers) writes the same rows, in the same order, as `-j 1`."""
    write_barn_world(tmp_path, 7)
    write_barn_world(tmp_path, 13)
    rows = {}
    for j in ("1", "2"):
        out = tmp_path / f"out{j}"
        res = CliRunner().invoke(app, ["barn", "run", "--worlds-dir", str(tmp_path), "--robot", "barn_jackal",
                                       "--executor", "local", "-j", j, "--out", str(out)])
        assert res.exit_code == 0, res.output
        lines = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]
        rows[j] = [{k: v for k, v in r.items() if k not in ("wall_s", "cpu_s")} for r in lines]
    assert [r["world_id"] for r in rows["1"]] == [7, 13]
    assert rows["2"] == rows["1"]


def test_a_job_that_dies_becomes_an_error_row(tmp_path):
    """A run whose job raises (here: a path file that is not a path) is reported as outcome 'error' with the
    reason, and the other worlds still run."""
    from fleet.grading.barn_suite import make_jobs, map_jobs
    from fleet.paths import robot_file
    from sim.robot_spec import load_robot_spec

    write_barn_world(tmp_path, 7)
    jobs = make_jobs(tmp_path, spec=load_robot_spec(robot_file("barn_jackal")))
    broken = [type(jobs[0])(**{**jobs[0].__dict__, "world_id": 8, "path": str(tmp_path / "missing.npy")})]
    rows = map_jobs(_raise_on_missing, broken + jobs, workers=1)
    assert [r["world_id"] for r in rows] == [8, 7]
    assert rows[0]["outcome"] == "error" and "missing.npy" in rows[0]["reason"] and not rows[0]["success"]
    assert rows[1]["outcome"] == "succeeded"


def _raise_on_missing(job):
    from fleet.grading.barn_run import run_barn_job

    if not Path(job.path).exists():
        raise FileNotFoundError(job.path)
    return run_barn_job(job)


AGENTS = Path(__file__).resolve().parent / "challenge_agents.py"


def test_an_agent_process_drives_a_barn_world_and_is_scored_by_barn_rules(tmp_path):
    """`--agent` runs the process over Zenoh in lock-step with the challenge placeholders; here it drives
    straight up the free column at 0.5 m/s: from 0.1 m off the start to 1 m from the goal is 8.9 m, so
    T = 17.8 s (± one 0.1 s tick) and the metric is BARN's formula of that T."""
    import sys

    write_barn_world(tmp_path, 7)
    out = tmp_path / "out"
    cmd = f"{sys.executable} {AGENTS} wall --connect {{connect}} --robot {{robot}} --goal {{goal_x}} {{goal_y}}"
    res = CliRunner().invoke(app, ["barn", "run", "--worlds-dir", str(tmp_path), "--robot", "barn_jackal",
                                   "--agent", cmd, "--out", str(out)])
    assert res.exit_code == 0, res.output
    (r,) = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]
    assert r["success"] and r["outcome"] == "succeeded" and r["controller"] == "agent", r
    assert r["time_s"] == pytest.approx(8.9 / 0.5, abs=0.15)
    assert r["barn_metric"] == pytest.approx(r["t_opt"] / min(max(r["time_s"], 2 * r["t_opt"]), 8 * r["t_opt"]),
                                             abs=1e-3)
    assert r["distance_to_goal"] <= 1.0 and not r["collided"]


@pytest.mark.parametrize("mode, outcome", [("crash", "agent_crashed"), ("hang", "agent_hung")])
def test_an_agent_that_crashes_or_hangs_is_a_graded_failure_with_its_reason(tmp_path, mode, outcome):
    """The agent fails the world (crash: an exception after 5 ticks; hang: silent after 5 ticks,
    caught by --tick-timeout) as a graded failure with its reason; the suite itself does not fail."""
    import sys

    write_barn_world(tmp_path, 7)
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["barn", "run", "--worlds-dir", str(tmp_path), "--robot", "barn_jackal",
                                   "--agent", f"{sys.executable} {AGENTS} {mode}", "--tick-timeout", "1",
                                   "--out", str(out)])
    assert res.exit_code == 0, res.output  # a graded failure, not a suite error
    (r,) = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]
    assert not r["success"] and r["outcome"] == outcome and r["barn_metric"] == 0.0, r
    assert 0 < r["path_length"] < 1.0  # it drove its 5 ticks at 0.5 m/s, then stopped counting
    if mode == "crash":
        assert "exit code" in r["reason"] and "controller blew up on purpose" in r["agent_log"]
    else:
        assert "1" in r["reason"] and r["reason"]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["outcomes"] == {outcome: 1}


def test_the_course_robot_sees_barn_obstacles_only_with_its_lidar_lowered(tmp_path):
    """The test world's cylinders are centred on the floor with length 1 (as BARN's): their tops are at 0.5 m.
    The course diffbot's lidar (0.57 m) gets no return; diffbot_low_lidar (mast 0.15 m → 0.42 m) sees them and
    is otherwise the course robot."""
    from fleet.paths import robot_file
    from sim.robot_spec import load_robot_spec

    course, low = (load_robot_spec(robot_file(n)) for n in ("diffbot", "diffbot_low_lidar"))
    assert course.lidar_height == pytest.approx(0.57) and low.lidar_height == pytest.approx(0.42)
    assert low.model_dump(exclude={"name", "mast"}) == course.model_dump(exclude={"name", "mast"})
    write_barn_world(tmp_path, 7)
    seen = {}
    for robot in ("diffbot", "diffbot_low_lidar"):
        out = tmp_path / robot
        res = CliRunner().invoke(app, ["barn", "run", "--worlds-dir", str(tmp_path), "--robot", robot,
                                       "--out", str(out)])
        assert res.exit_code == 0, res.output
        (r,) = [json.loads(line) for line in (out / "results.jsonl").read_text().splitlines()]
        seen[robot] = r["lidar_returns_per_scan"]
        warnings = json.loads((out / "summary.json").read_text())["warnings"]
        assert bool(warnings) == (robot == "diffbot")
    assert seen["diffbot"] == 0 and seen["diffbot_low_lidar"] > 0
