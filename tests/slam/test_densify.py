"""End-of-log densification (`slam.densify`): keyframes matched against their spatial neighbours in the optimised
graph add constraints that agree with the ground truth, and the map does not get worse; long-range matches
(`slam.densify_groups`) go in only as groups that agree."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from sim.transforms import se2_between
from slam.densify import Densifier, DensifyConfig, _every, _near
from slam.densify_groups import _clusters, add_groups
from slam.log_config import LogSlamConfig
from slam.log_eval import evaluate
from slam.log_run import load_log, run_slam
from slam.log_slam import LogSlam
from slam.loop_groups import Pending
from tests.slam import carmen_synth


def test_every_takes_the_first_node_of_each_stretch() -> None:
    path = np.array([0.0, 0.4, 0.9, 1.0, 1.7, 2.05, 2.1, 3.2])
    assert _every(path, 1.0) == [0, 3, 5, 7]  # 0, then the first at ≥ 1.0, ≥ 2.05, ≥ 3.05 m


def test_densified_constraints_match_the_truth(tmp_path: Path) -> None:
    rng = np.random.default_rng(5)
    truth = carmen_synth.loop(200, 0.25)  # one 48.6 m lap and back past the start
    odom = carmen_synth.drifted(truth, 0.006, rng)
    carmen_synth.write_log(tmp_path / "loop.log.gz", truth, odom, rng)
    cfg = LogSlamConfig.model_validate({"densify": {"enabled": False}})
    log = load_log(tmp_path / "loop.log.gz", cfg)
    assert log.reference is not None
    slam = run_slam(log, cfg)
    ref = log.reference
    before = float(evaluate(np.array(slam.poses), ref)["ate_rmse"])  # type: ignore[arg-type]
    dz = Densifier(DensifyConfig(every_distance=1.0), slam)
    dz.run()
    assert dz.added >= 3, "the lap's end overlaps its start: keyframes there have neighbours 45 m back"
    for a, i, rel in dz.constraints:
        assert abs(slam.path[i] - slam.path[a]) >= dz.config.min_path_separation
        err = se2_between(tuple(ref[a]), tuple(ref[i]))
        off = se2_between(err, rel)
        assert math.hypot(off[0], off[1]) < 0.05 and abs(off[2]) < math.radians(1.0), (a, i, off)
    after = float(evaluate(np.array(slam.poses), ref)["ate_rmse"])  # type: ignore[arg-type]
    assert after == pytest.approx(before, abs=0.005)  # a consistent graph stays where it was


def _offset_line(n: int = 40, jump: float = 0.8) -> LogSlam:
    """Poses 0 … n − 1 along x, 1 m apart; the edge 20 → 21 is loose (σ 1 m) and says the path jumped `jump` m
    sideways, which it did not. No scans: only the graph side of `LogSlam` is used."""
    slam = LogSlam()
    g = slam.graph
    tight, loose = np.diag([1e-4, 1e-4, 1e-6]), np.diag([1.0, 1.0, 1e-6])
    g.add_pose((0.0, 0.0, 0.0))
    for i in range(1, n):
        g.add_pose((float(i), jump if i > 20 else 0.0, 0.0), (1.0, jump if i == 21 else 0.0, 0.0),
                   loose if i == 21 else tight)
    g.update()
    slam.refresh_poses()
    slam.path = [float(i) for i in range(n)]
    return slam


def _truth_match(target: int, source: int, dy: float = 0.0) -> Pending:
    return Pending(target, source, (float(source - target), dy, 0.0), np.diag([0.03**2, 0.03**2, 0.01**2]),
                   0.4, 0.4, 0.03)


def test_an_agreeing_group_pulls_the_loose_stretch_back() -> None:
    slam = _offset_line()
    assert slam.poses[30][1] == pytest.approx(0.8, abs=1e-6)
    kept = add_groups(slam, [_truth_match(t, s) for t, s in ((2, 30), (3, 31), (4, 32), (5, 33))])
    assert len(kept) == 4
    assert abs(slam.poses[30][1]) < 0.01 and abs(slam.poses[39][1]) < 0.01  # the loose edge took the correction


def test_too_small_or_disagreeing_groups_are_not_added() -> None:
    slam = _offset_line()
    assert add_groups(slam, [_truth_match(2, 30), _truth_match(3, 31)]) == []  # two agree, three are needed
    rng = np.random.default_rng(1)
    scattered = [_truth_match(t, s, float(rng.uniform(-2, 2))) for t, s in ((2, 30), (3, 31), (4, 32), (5, 33))]
    assert add_groups(slam, scattered) == []  # no three agree pairwise within 0.3 m
    assert slam.poses[30][1] == pytest.approx(0.8, abs=1e-6)


def test_clusters_split_where_sources_are_far_apart_along_the_path() -> None:
    path = [float(i) for i in range(100)]
    ms = [_truth_match(0, s) for s in (50, 12, 14, 30, 21)]
    assert [[p.source for p in c] for c in _clusters(ms, path, 10.0)] == [[12, 14, 21, 30], [50]]
    assert _near(np.array([1.0, 5.0, 9.0]), 6.5, 1.5) and not _near(np.array([1.0, 5.0, 9.0]), 7.0, 1.5)
