"""End-of-log densification (`slam.densify`): keyframes matched against their spatial neighbours in the optimised
graph add constraints that agree with the ground truth, and the map does not get worse."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from sim.transforms import se2_between
from slam.densify import Densifier, DensifyConfig, _every
from slam.log_config import LogSlamConfig
from slam.log_eval import evaluate
from slam.log_run import load_log, run_slam
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
