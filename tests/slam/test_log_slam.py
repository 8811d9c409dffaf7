"""Log SLAM on a simulated CARMEN log: drifted odometry is corrected, a loop the odometry misses by metres
is closed, a deliberately wrong closure is rejected without moving the map, and `fleetnav slam run|eval`
write every output."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from fleetnav.cli import app
from slam.log_config import LogSlamConfig
from slam.log_eval import evaluate, read_tum
from slam.log_run import load_log, run_slam
from slam.log_slam import LogSlam
from tests.slam import carmen_synth

N = 200  # scans 0.25 m apart: 50 m, one 48.6 m lap and back past the start


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[LogSlam, np.ndarray, np.ndarray, Path]:
    rng = np.random.default_rng(3)
    truth = carmen_synth.loop(N, 0.25)
    odom = carmen_synth.drifted(truth, 0.006, rng)  # 0.006 rad of heading error per metre
    path = tmp_path_factory.mktemp("log") / "loop.log.gz"
    carmen_synth.write_log(path, truth, odom, rng)
    log = load_log(path, LogSlamConfig())
    slam = run_slam(log, LogSlamConfig())
    assert log.reference is not None
    return slam, log.reference, np.array([o.as_tuple() for o in odom]), path


def test_drifted_odometry_is_mapped_and_the_loop_closed(run: tuple[LogSlam, np.ndarray, np.ndarray, Path]) -> None:
    slam, ref, odom, _ = run
    _, est = slam.trajectory()
    # the lap returns to its start after 48.6 m (scan 195): odometry puts it metres away
    back = 195
    miss = math.hypot(*(odom[back, :2] - odom[0, :2])) - math.hypot(*(ref[back, :2] - ref[0, :2]))
    assert miss > 2.0
    s, o = evaluate(est, ref), evaluate(odom, ref)
    assert float(s["ate_rmse"]) < 0.05 < 0.5 < float(o["ate_rmse"])  # type: ignore[arg-type]
    rot = s["rpe_consecutive"]["rot_mean_deg"]  # type: ignore[index]
    assert rot < 0.5
    closing = [c for c in slam.loops.history if c.accepted and c.source >= 185 and c.target <= 30]
    assert closing, f"no closure from the end of the lap to its start: {slam.loops.reasons}"
    assert slam.stats.odometry_only == 0


def test_wrong_closure_is_rejected_and_the_map_unchanged(run: tuple[LogSlam, np.ndarray, np.ndarray, Path]) -> None:
    slam, ref, _, _ = run
    _, before = slam.trajectory()
    ate0 = float(evaluate(before, ref)["ate_rmse"])  # type: ignore[arg-type]
    cov = np.diag([0.03**2, 0.03**2, 0.01**2])
    wrong = slam.loops.add(20, 120, (2.0, -1.5, 0.8), cov)  # scan 120 is nowhere near scan 20 this way
    assert not wrong.accepted and wrong.reason == "inconsistent_after_optimisation"
    _, after = slam.trajectory()
    assert abs(float(evaluate(after, ref)["ate_rmse"]) - ate0) < 0.01  # type: ignore[arg-type]
    assert np.abs(after[:, :2] - before[:, :2]).max() < 0.01


def test_closure_gtsam_cannot_solve_is_dropped_and_slam_goes_on(
        run: tuple[LogSlam, np.ndarray, np.ndarray, Path]) -> None:
    """A NaN closure makes iSAM2 throw IndeterminateLinearSystemException; the closure is rejected with that
    reason, the map stays, and a later closure is still added."""
    slam, _, _, _ = run
    _, before = slam.trajectory()
    cov = np.diag([0.03**2, 0.03**2, 0.01**2])
    bad = slam.loops.add(20, 120, (math.nan, 0.0, 0.0), cov)
    assert not bad.accepted and bad.reason == "graph_indeterminate"
    _, after = slam.trajectory()
    assert np.abs(after[:, :2] - before[:, :2]).max() < 0.01
    x0, y0, t0 = slam.poses[150]
    x1, y1, t1 = slam.poses[160]
    c, s = math.cos(t0), math.sin(t0)
    now = (c * (x1 - x0) + s * (y1 - y0), -s * (x1 - x0) + c * (y1 - y0), t1 - t0)
    assert slam.loops.add(150, 160, now, cov).accepted  # the graph still works


def test_cli_run_and_eval(run: tuple[LogSlam, np.ndarray, np.ndarray, Path], tmp_path: Path) -> None:
    _, _, _, path = run
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["slam", "run", str(path), "--out", str(out), "--quiet"])
    assert res.exit_code == 0, res.output
    for name in ("map.pgm", "map.yaml", "map.png", "trajectory.tum", "trajectory_odom.tum", "graph.g2o",
                 "report.json", "reference.tum", "config.yaml", "overlay.png"):
        assert (out / name).is_file(), name
    report = json.loads((out / "report.json").read_text())
    assert report["scans"] == N and report["slam"]["ate_rmse"] < 0.05 and report["loop_closures"]["accepted"] >= 1
    assert report["odometry_only"]["ate_rmse"] > 0.5 and report["ms_per_scan"] > 0
    stamps, poses = read_tum(out / "trajectory.tum")
    assert len(stamps) == N and stamps[1] == pytest.approx(0.5)
    g2o = (out / "graph.g2o").read_text().splitlines()
    assert sum(line.startswith("VERTEX_SE2") for line in g2o) == N
    assert sum(line.startswith("EDGE_SE2") for line in g2o) >= N - 1 + report["loop_closures"]["accepted"]
    ev = CliRunner().invoke(app, ["slam", "eval", str(out / "trajectory.tum"), str(out / "reference.tum")])
    assert ev.exit_code == 0, ev.output
    assert json.loads(ev.output)["ate_rmse"] == pytest.approx(report["slam"]["ate_rmse"], abs=1e-5)
    bad = CliRunner().invoke(app, ["slam", "run", str(tmp_path / "missing.log"), "--out", str(out)])
    assert bad.exit_code == 2 and "cannot read" in bad.output
    assert poses.shape == (N, 3)


def test_mcap_log_without_odometry(tmp_path: Path) -> None:
    """An MCAP recording has scans only: every step is matched in the wide window from a constant-velocity
    guess, and the lap's first 10 m still come out within a few centimetres."""
    from dataclasses import replace

    from slam.io_mcap import write_mcap_scans
    from tests.slam import synth

    rng = np.random.default_rng(2)
    truth = carmen_synth.loop(40, 0.25)
    scans = [replace(synth.raycast(carmen_synth.SEGS, p, noise=0.01, rng=rng), stamp=0.5 * k)
             for k, p in enumerate(truth)]
    write_mcap_scans(tmp_path / "lap.mcap", scans)
    log = load_log(tmp_path / "lap.mcap", LogSlamConfig())
    assert log.kind == "mcap" and not log.odom_valid.any() and log.reference is None
    slam = run_slam(log, LogSlamConfig())
    _, est = slam.trajectory()
    ref = np.array([p.as_tuple() for p in truth])
    assert float(evaluate(est, ref)["ate_rmse"]) < 0.05  # type: ignore[arg-type]
    assert slam.stats.wide == len(truth) - 1 and slam.stats.odometry_only == 0


def test_only_a_closure_far_from_the_estimate_gets_the_strong_kernel(
        run: tuple[LogSlam, np.ndarray, np.ndarray, Path]) -> None:
    slam, _, _, _ = run
    loops = slam.loops
    assert loops.config.strong_kernel_beyond == 0.3 and loops.config.kernel == "huber"
    x0, y0, t0 = slam.poses[20]
    x1, y1, t1 = slam.poses[120]
    c, s = math.cos(t0), math.sin(t0)
    now = (c * (x1 - x0) + s * (y1 - y0), -s * (x1 - x0) + c * (y1 - y0), t1 - t0)  # 120 in 20's frame
    assert loops.kernel_for(20, 120, now) == "huber"
    assert loops.kernel_for(20, 120, (now[0] + 0.2, now[1] - 0.2, now[2])) == "huber"  # 0.28 m off
    assert loops.kernel_for(20, 120, (now[0] + 0.25, now[1] - 0.25, now[2])) == "cauchy"  # 0.35 m off


def test_front_end_edge_floor_grows_with_the_ground_covered() -> None:
    fe = LogSlamConfig().frontend
    assert fe.sigma_floor_length == 1.0 and fe.sigma_floor_m_per_rad == 0.5
    slam = LogSlam()
    unit = np.diag([fe.sigma_floor_xy**2, fe.sigma_floor_xy**2, fe.sigma_floor_yaw**2])
    np.testing.assert_allclose(slam._floor((0.3, 0.4, 0.0)), 0.5 * unit)  # 0.5 m straight
    np.testing.assert_allclose(slam._floor((1.2, -1.6, 0.0)), 2.0 * unit)  # 2 m
    np.testing.assert_allclose(slam._floor((0.0, 0.0, -1.0)), 0.5 * unit)  # 1 rad turned on the spot
    np.testing.assert_allclose(slam._floor((0.6, 0.0, 0.8)), 1.0 * unit)  # 0.6 m + 0.8 rad
    np.testing.assert_allclose(slam._floor((0.001, 0.0, 0.0)), fe.sigma_floor_min_share * unit)  # standing
