"""Wide-window seeds from several motion models (`slam.motion_models`) on a simulated log without odometry.

The robot drives along the room in steps growing to 3 m, then stops and turns in place. The constant-velocity
prediction is then 3 m ahead, so the truth lies outside its ±2.5 m window; the no-motion model's window holds
it. Ground truth is the simulated poses.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from sim.types import Pose2D
from slam.csm import CsmResult
from slam.log_config import LogSlamConfig
from slam.log_eval import evaluate
from slam.log_run import load_log, run_slam
from slam.motion_models import MotionModelsConfig, gate, model_steps
from tests.slam import carmen_synth


def _run(path: Path, models: bool) -> tuple[float, np.ndarray]:
    cfg = LogSlamConfig(odometry="none")
    cfg.hypotheses.models.enabled = models
    log = load_log(path, cfg)
    assert log.reference is not None
    _, est = run_slam(log, cfg).trajectory()
    return float(evaluate(est, log.reference)["ate_rmse"]), est  # type: ignore[arg-type]


@pytest.mark.parametrize("turns", [(70.0, 70.0, 70.0), (-60.0, -120.0)])
def test_a_stop_and_turn_is_found_by_the_no_motion_model(tmp_path: Path, turns: tuple[float, ...]) -> None:
    xs = [3.6, 5.6, 8.4, 11.4] + [11.4] * len(turns)
    yaws = [0.0] * 4 + [math.radians(t) for t in turns]
    truth = [Pose2D(x, 3.0, y) for x, y in zip(xs, yaws, strict=True)]
    path = tmp_path / "stop_turn.log"
    carmen_synth.write_log(path, truth, truth, np.random.default_rng(3))
    ate_cv, est_cv = _run(path, models=False)
    ate, est = _run(path, models=True)
    # constant velocity alone drives on (or turns in the wrong place): metres off
    assert ate_cv > 0.5, ate_cv
    assert ate < 0.03, ate
    # the stop: every pose after the 4th is where the 4th is (map frame = the first pose), turned as the truth
    stop = est[3, :2]
    assert np.allclose(est[4:, :2], stop, atol=0.05)
    assert np.allclose(np.remainder(est[4:, 2] - yaws[4:] + math.pi, math.tau) - math.pi, 0.0, atol=0.03)
    assert not np.allclose(est_cv[4:, :2], stop, atol=0.05)


def test_model_steps_and_gate() -> None:
    cfg = MotionModelsConfig(enabled=True, models=["zero", "straight", "fast", "median"])
    poses = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (3.0, 0.0, math.pi / 2), (3.0, 3.0, math.pi / 2)]
    # steps (own frame): (1, 0, 0), (2, 0, π/2), (3, 0, 0): speed median 2, top 3, componentwise median (2, 0, 0)
    zero, straight, fast, median = model_steps(poses, cfg)
    assert fast == pytest.approx((3.0, 0.0, 0.0), abs=1e-12)
    assert zero == (0.0, 0.0, 0.0)
    assert straight == pytest.approx((2.0, 0.0, 0.0), abs=1e-12)
    assert median == pytest.approx((2.0, 0.0, 0.0), abs=1e-12)
    assert model_steps(poses[:1], cfg) == [(0.0, 0.0, 0.0)]
    guess = (5.0, 5.0, 0.0)
    assert gate(None, guess, cfg)
    assert gate(CsmResult(guess, cfg.weak - 0.01, 0), guess, cfg)  # weak
    near = (5.0 + cfg.off_xy - 0.1, 5.0, cfg.off_yaw - 0.1)
    assert not gate(CsmResult(near, cfg.weak + 0.1, 0), guess, cfg)  # strong, near its prediction
    assert gate(CsmResult((5.0 + cfg.off_xy + 0.1, 5.0, 0.0), 0.9, 0), guess, cfg)  # strong but far from it
    assert gate(CsmResult((5.0, 5.0, cfg.off_yaw + 0.1), 0.9, 0), guess, cfg)  # … or turned far from it
    assert not gate(None, guess, MotionModelsConfig(enabled=False))
