"""Write simulated CARMEN logs for the log-SLAM tests: FLASER lines (181 beams over 180°) with exact poses,
ODOM lines with drifted wheel odometry (two per scan, straddling it in time)."""

from __future__ import annotations

import gzip
import math
from pathlib import Path

import numpy as np

from sim.types import Pose2D
from slam.log_config import LogSlamConfig
from slam.log_slam import LogSlam
from tests.slam import synth

SEGS = synth.room()


def loop(n: int, step: float) -> list[Pose2D]:
    """A rectangular lap of the room clear of every obstacle (≥ 0.3 m), 44 m, corners turned over ~1 m."""
    return synth.polygon_path([(3.6, 3.0), (18.0, 3.0), (18.0, 12.9), (3.6, 12.9)], n, step, smooth=5)


def drifted(truth: list[Pose2D], yaw_bias_per_m: float, rng: np.random.Generator) -> list[Pose2D]:
    return synth.wheel_odometry(truth, rng, slip=0.01, bias=yaw_bias_per_m)


def flaser_line(pose: Pose2D, odom: Pose2D, stamp: float, rng: np.random.Generator, beams: int = 181,
                segments: np.ndarray = SEGS, max_range: float = 10.0) -> str:
    """`beams` beams from −90° to +90° (the 180°/(n−1) layout), range noise 1 cm, no return written as
    `max_range`."""
    full = synth.raycast(segments, pose, beams=2 * (beams - 1), max_range=max_range, noise=0.01, rng=rng)
    r = full.ranges[(beams - 1) // 2:(beams - 1) // 2 + beams]  # −90° … +90°
    vals = " ".join(f"{(v if math.isfinite(v) else max_range):.3f}" for v in r)
    return (f"FLASER {beams} {vals} {pose.x:.6f} {pose.y:.6f} {pose.yaw:.6f} {pose.x:.6f} {pose.y:.6f} "
            f"{pose.yaw:.6f} {stamp:.6f} synth {stamp:.6f}")


def write_log(path: Path, truth: list[Pose2D], odom: list[Pose2D], rng: np.random.Generator, dt: float = 0.5,
              segments: np.ndarray = SEGS, max_range: float = 10.0) -> None:
    """Scans every `dt` s; ODOM lines at t ± dt/4 hold the odometry interpolated there (linear in x, y, yaw
    between the scan's odometry poses), so reading them back and interpolating to t gives `odom` exactly."""
    lines = ["# simulated CARMEN log (fleetnav tests)"]
    for k, (p, o) in enumerate(zip(truth, odom, strict=True)):
        t = k * dt
        if k > 0:
            lines.append(_odom(_mid(odom[k - 1], o, 0.75), t - dt / 4))
        lines.append(_odom(o, t))
        lines.append(flaser_line(p, o, t, rng, segments=segments, max_range=max_range))
    text = "\n".join(lines) + "\n"
    if path.suffix == ".gz":
        with gzip.open(path, "wt", encoding="utf-8") as f:
            f.write(text)
    else:
        path.write_text(text, encoding="utf-8")


def _mid(a: Pose2D, b: Pose2D, f: float) -> Pose2D:
    dyaw = math.remainder(b.yaw - a.yaw, math.tau)
    return Pose2D(a.x + f * (b.x - a.x), a.y + f * (b.y - a.y), a.yaw + f * dyaw)


def _odom(o: Pose2D, t: float) -> str:
    return f"ODOM {o.x:.6f} {o.y:.6f} {o.yaw:.6f} 0.5 0.0 0.0 {t:.6f} synth {t:.6f}"


def run_scored(path: str | Path, cfg: LogSlamConfig) -> tuple[LogSlam, np.ndarray, float]:
    """Run the log SLAM on a written log: (the SLAM, the log's reference poses, ATE RMSE against them)."""
    from slam.log_eval import evaluate
    from slam.log_run import load_log, run_slam

    log = load_log(path, cfg)
    assert log.reference is not None
    slam = run_slam(log, cfg)
    ate = evaluate(slam.trajectory()[1], log.reference)["ate_rmse"]
    assert isinstance(ate, float)
    return slam, log.reference, ate
