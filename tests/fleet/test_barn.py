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
