"""Run SLAM on a recorded log (CARMEN .log/.log.gz or MCAP) and write the results to a folder:

map.pgm + map.yaml (map_server), map.png (map with the trajectory in red, odometry in blue),
trajectory.tum (optimised, one pose per scan), trajectory_odom.tum (the odometry used), graph.g2o,
report.json (scans, loop closures with reasons, ms/scan, real-time factor and, when the log has reference
poses, ATE/RPE against them for the SLAM estimate and for odometry alone); reference.tum when it exists.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image, ImageDraw

from planning.grid import OccupancyGrid
from planning.map_io import save_map
from sim.errors import ErrorCode, FleetError
from slam import se2
from slam.log_config import LogSlamConfig
from slam.log_eval import evaluate, write_g2o, write_tum
from slam.log_slam import LogSlam
from slam.types import ScanRecord

Progress = Callable[[int, int, float], None]  # (done, total, mean ms per scan so far)


@dataclass(frozen=True, slots=True)
class LoadedLog:
    records: list[ScanRecord]
    odom_valid: np.ndarray
    reference: np.ndarray | None
    kind: str
    reference_kind: str = "none"  # CARMEN: what the laser lines' poses are (`slam.io_carmen`)
    odom_rates: np.ndarray | None = None  # (n, 4) odometry rate at each scan's stamp and its interval (slam.deskew)


def load_log(path: str | Path, config: LogSlamConfig) -> LoadedLog:
    p = Path(path)
    name = p.name.lower()
    if name.endswith((".log", ".log.gz", ".clf", ".clf.gz")):
        from slam.io_carmen import read_carmen

        log = read_carmen(p, odometry=config.odometry, laser=config.laser, max_range=80.0)
        valid = log.odom_valid if log.odom_valid is not None else np.zeros(len(log.records), dtype=bool)
        return LoadedLog(log.records, valid, log.reference, "carmen", log.reference_kind, log.odom_rates)
    if name.endswith(".mcap"):
        from slam.io_mcap import read_mcap_scans

        recs = list(read_mcap_scans(p))
        if not recs:
            raise FleetError(ErrorCode.NOT_FOUND, f"{p}: no LaserScan messages", "record a scan topic")
        valid = np.array([r.odom is not None for r in recs])
        return LoadedLog(recs, valid, None, "mcap")
    raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{p}: unknown log type",
                     "give a CARMEN .log / .log.gz (or .clf) or an .mcap recording")


def run_slam(log: LoadedLog, config: LogSlamConfig, progress: Progress | None = None) -> LogSlam:
    slam = LogSlam(config)  # the map frame is the first scan's pose: the reference is never an input
    n = len(log.records)
    t0 = time.perf_counter()
    for k, rec in enumerate(log.records):
        r = None if log.odom_rates is None else log.odom_rates[k]
        rate = (float(r[0]), float(r[1]), float(r[2]), float(r[3])) if r is not None and np.isfinite(r).all() \
            else None
        slam.add_scan(rec.scan, rec.odom, bool(log.odom_valid[k]), rate=rate,
                      lookahead=[r.scan for r in log.records[k + 1:k + 1 + config.lookahead.depth]])
        if progress is not None and (k % 25 == 0 or k == n - 1):
            progress(k + 1, n, 1000 * (time.perf_counter() - t0) / (k + 1))
    slam.finish()
    return slam


def write_outputs(slam: LogSlam, log: LoadedLog, out: str | Path, wall: float, source: str) -> dict[str, Any]:
    out_dir = Path(out)
    out_dir.mkdir(parents=True, exist_ok=True)
    stamps, est = slam.trajectory()
    odo = slam.odometry_trajectory()
    write_tum(out_dir / "trajectory.tum", stamps, est)
    write_tum(out_dir / "trajectory_odom.tum", stamps, odo)
    write_g2o(out_dir / "graph.g2o", est, slam.edges)
    grid = slam.map()
    save_map(grid, out_dir / "map.yaml")
    save_png(grid, est, odo, out_dir / "map.png")
    n = len(est)
    span = float(stamps[-1] - stamps[0]) if n > 1 else 0.0
    closures = slam.loops.history
    report: dict[str, Any] = {
        "log": source, "kind": log.kind, "scans": n, "odometry": slam.config.odometry,
        "odometry_steps_missing": int((~log.odom_valid[1:]).sum()) if n > 1 else 0,
        "front_end": {"matched": slam.stats.matched, "wide_window": slam.stats.wide,
                      "odometry_only": slam.stats.odometry_only, "ambiguous": slam.stats.ambiguous,
                      # the interlace delay learnt by `slam.deskew` (0: the scans were left as they are)
                      "deskew_delay_ms": 1000 * slam.deskew_delay},
        "loop_closures": {"accepted": sum(c.accepted for c in closures),
                          "rejected": sum(not c.accepted for c in closures),
                          "reasons": dict(slam.loops.reasons), "list": [c.as_dict() for c in closures]},
        "pose_graph_repairs": slam.graph.repairs,  # failed GTSAM steps and what was dropped (PoseGraph._repair)
        "ms_per_scan": 1000 * wall / max(n, 1),
        "cpu_ms_per_scan": 1000 * (float(np.sum(slam.stats.cpu_times)) + slam.stats.finish_cpu) / max(n, 1),
        "finish_cpu_ms_per_scan": 1000 * slam.stats.finish_cpu / max(n, 1),
        "densify": {"added": slam.densifier.added, "rejected": slam.densifier.rejected,
                    "group_added": slam.densifier.group_added, "group_candidates": slam.densifier.group_candidates},
        "ms_per_scan_p95": float(np.percentile(slam.stats.times, 95) * 1000) if slam.stats.times else 0.0,
        "wall_s": wall, "log_duration_s": span, "real_time_factor": span / wall if wall > 0 and span > 0 else None,
    }
    if log.reference is not None:
        report["reference"] = {"source": "laser-line poses", "kind": log.reference_kind,
                               "note": _REFERENCE_NOTES.get(log.reference_kind, "")}
    if log.reference is not None and len(log.reference) == n and log.reference_kind != "raw_odometry":
        write_tum(out_dir / "reference.tum", stamps, log.reference)
        report["slam"] = evaluate(est, log.reference)
        report["odometry_only"] = evaluate(odo, log.reference)
        aligned = se2.compose_many(np.tile(report["slam"]["alignment"], (n, 1)), est)
        save_overlay(slam.map(log.reference), slam.map(aligned), out_dir / "overlay.png")
    (out_dir / "report.json").write_text(json.dumps(report, indent=1), encoding="utf-8")
    return report


_REFERENCE_NOTES = {
    "corrected": "the ODOM stream restarts at them: corrected poses (Radish -corrected log)",
    "raw_odometry": "they lie on the ODOM stream: raw wheel odometry, not a reference; no ATE/RPE reported",
    "independent": "not on the ODOM stream (e.g. a simulator's true poses): scored as a reference",
    "unknown": "no ODOM lines to tell whether they are corrected poses or raw odometry: ATE/RPE against them "
               "may only measure the distance to the raw odometry",
}


def run_log(path: str | Path, out: str | Path, config: LogSlamConfig | None = None,
            progress: Progress | None = None) -> dict[str, Any]:
    cfg = config or LogSlamConfig()
    log = load_log(path, cfg)
    t0 = time.perf_counter()
    slam = run_slam(log, cfg, progress)
    wall = time.perf_counter() - t0
    return write_outputs(slam, log, out, wall, str(path))


def save_overlay(reference: OccupancyGrid, estimate: OccupancyGrid, path: Path, max_px: int = 1600) -> Path:
    """Walls of the map built at the reference poses (blue) and at the aligned estimate (red); where both
    agree the wall is black. A doubled wall shows as parallel red and blue lines."""
    res = reference.resolution
    lo = np.minimum(reference.bounds[:2], estimate.bounds[:2])
    hi = np.maximum(reference.bounds[2:], estimate.bounds[2:])
    w, h = (np.ceil((hi - lo) / res).astype(int) + 1).tolist()
    layers = []
    for g in (reference, estimate):
        rows, cols = np.nonzero(g.data >= 50)
        xy = g.cells_to_world(rows, cols)
        c = np.floor((xy - lo) / res).astype(int)
        m = np.zeros((h, w), dtype=bool)
        m[c[:, 1], c[:, 0]] = True
        layers.append(m)
    img = np.full((h, w, 3), 255, dtype=np.uint8)
    img[layers[0]] = (60, 90, 255)
    img[layers[1]] = (230, 30, 30)
    img[layers[0] & layers[1]] = (0, 0, 0)
    pil = Image.fromarray(np.flipud(img), mode="RGB")
    scale = min(2.0, max_px / max(pil.size))
    pil = pil.resize((max(1, round(pil.width * scale)), max(1, round(pil.height * scale))), Image.Resampling.NEAREST)
    pil.save(path, format="PNG", optimize=True)
    return path


def save_png(grid: OccupancyGrid, est: np.ndarray, odo: np.ndarray | None, path: Path, max_px: int = 1600) -> Path:
    """The map (black walls, white free, grey unknown), odometry in blue, the estimate in red."""
    d = grid.data
    px = np.full(d.shape, 160, dtype=np.uint8)
    px[(d >= 0) & (d < 50)] = 255
    px[d >= 50] = 0
    img = Image.fromarray(np.flipud(px), mode="L").convert("RGB")
    scale = min(2.0, max_px / max(img.size))
    if scale != 1.0:
        img = img.resize((max(1, round(img.width * scale)), max(1, round(img.height * scale))),
                         Image.Resampling.NEAREST)
    draw = ImageDraw.Draw(img)
    h = grid.height

    def to_px(xy: np.ndarray) -> list[tuple[float, float]]:
        c = (xy[:, 0] - grid.origin[0]) / grid.resolution * scale
        r = (h - (xy[:, 1] - grid.origin[1]) / grid.resolution) * scale
        return list(zip(c.tolist(), r.tolist(), strict=True))

    if odo is not None and len(odo) > 1:
        draw.line(to_px(odo[:, :2]), fill=(60, 90, 255), width=1)
    if len(est) > 1:
        draw.line(to_px(est[:, :2]), fill=(230, 30, 30), width=2)
    img.save(path, format="PNG", optimize=True)
    return path
