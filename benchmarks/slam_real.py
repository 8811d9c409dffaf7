"""SLAM on real robot logs: every CARMEN log in ../shared/data/carmen/ (the five Radish "-corrected" logs
there today, and any other `*.log`, `*.log.gz`, `*.clf`, `*.clf.gz` put beside them), raw wheel odometry (the
ODOM increments), ONE default config for all of them (slam/log_config.py). A log without reference poses is
mapped and timed, and its ATE/RPE are reported as missing.

Per log: ATE RMSE (after SE(2) alignment) against the laser lines' corrected poses, RPE (consecutive scans,
1 m, 10 m), loop closures, ms/scan, for
  new   `fleetnav slam run` (correlative scan-to-local-map + ICP front end, branch-and-bound loop closure,
        GTSAM with a robust kernel)
  odom  the raw odometry alone (same run)
  old   the previous pipeline (slam.SlamPipeline: KISS-ICP + keyframe ICP loop closure), same odometry

    nice -n 10 .venv/bin/python benchmarks/slam_real.py [--logs orebro,seattle|PATH,...] [--data DIR]
                                                         [--no-old] [--out DIR] [--config FILE]
"""

from __future__ import annotations

import sys
from pathlib import Path

# Run as a script, this file's folder comes first on sys.path and its name would shadow the slam package.
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]

import argparse  # noqa: E402
import gc  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from typing import Any  # noqa: E402

from sim.config import load_yaml  # noqa: E402
from slam.log_config import LogSlamConfig  # noqa: E402
from slam.log_eval import evaluate  # noqa: E402
from slam.log_run import load_log, run_slam, write_outputs  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
# ../shared/data/carmen beside the checkout (a git worktree may sit one level deeper)
DATA = next((d / "shared" / "data" / "carmen" for d in ROOT.parents if (d / "shared" / "data" / "carmen").is_dir()),
            ROOT.parent / "shared" / "data" / "carmen")
LOG_SUFFIXES = (".log.gz", ".clf.gz", ".log", ".clf")


def log_name(path: Path) -> str:
    """`freiburg-079-corrected.log.gz` -> `freiburg-079`."""
    name = path.name
    for suffix in LOG_SUFFIXES:
        if name.endswith(suffix):
            name = name[: -len(suffix)]
            break
    return name.removesuffix("-corrected")


def find_logs(data: Path, wanted: str | None) -> list[Path]:
    """Every log in `data`, or the comma-separated names (as printed by `log_name`) or paths in `wanted`."""
    found = sorted(p for p in data.iterdir() if p.name.endswith(LOG_SUFFIXES)) if data.is_dir() else []
    if not wanted:
        return found
    by_name = {log_name(p): p for p in found}
    out = []
    for item in wanted.split(","):
        if item in by_name:
            out.append(by_name[item])
        elif Path(item).is_file():
            out.append(Path(item))
        else:
            raise SystemExit(f"no log {item!r}: known in {data}: {', '.join(by_name) or 'none'}")
    return out


def run_old(path: Path) -> dict[str, float]:
    from slam import SlamPipeline

    log = load_log(path, LogSlamConfig())
    assert log.reference is not None
    slam = SlamPipeline()
    t0 = time.perf_counter()
    for rec in log.records:
        slam.process_scan(rec.scan, rec.odom)
    wall = time.perf_counter() - t0
    _, est = slam.trajectory()
    n = len(est)
    ref = log.reference[len(log.records) - n:]  # scans before the first with returns have no pose
    m: dict[str, Any] = evaluate(est, ref)
    return {"ate": float(m["ate_rmse"]), "rot_deg": float(m["rpe_consecutive"]["rot_mean_deg"]),
            "ms": 1000 * wall / max(n, 1), "loops": float(slam.status().loop_closures_accepted)}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--logs", default=None, help="comma-separated log names or paths (default: every log in --data)")
    ap.add_argument("--data", type=Path, default=DATA, help=f"folder of CARMEN logs (default {DATA})")
    ap.add_argument("--no-old", action="store_true", help="skip the previous pipeline (slow on freiburg-079)")
    ap.add_argument("--out", type=Path, default=None, help="keep each run's outputs here (default: a temp dir)")
    ap.add_argument("--config", type=Path, default=None, help="YAML with LogSlamConfig fields instead of the "
                    "default (e.g. a baseline for a before/after table)")
    args = ap.parse_args()
    paths = find_logs(args.data, args.logs)
    if not paths:
        print(f"no data: no CARMEN logs in {args.data} (the logs live outside the repo); nothing measured")
        return 0
    out_root = args.out or Path(tempfile.mkdtemp(prefix="slam_real_"))
    rows = []
    for path in paths:
        name = log_name(path)
        cfg = load_yaml(args.config, LogSlamConfig) if args.config else LogSlamConfig()
        log = load_log(path, cfg)
        t0 = time.perf_counter()
        slam = run_slam(log, cfg)
        wall = time.perf_counter() - t0
        rep = write_outputs(slam, log, out_root / name, wall, str(path))
        if "slam" not in rep:  # no reference poses: nothing to score against
            row = {"log": name, "scans": rep["scans"], "ms": rep["ms_per_scan"], "cpu_ms": rep["cpu_ms_per_scan"],
                   "loops": rep["loop_closures"]["accepted"], "rejected": rep["loop_closures"]["rejected"],
                   "no_reference": True}
            rows.append(row)
            print(json.dumps(row), flush=True)
            del slam, log
            gc.collect()
            continue
        s: dict[str, Any] = rep["slam"]
        o: dict[str, Any] = rep["odometry_only"]
        row = {"log": name, "scans": rep["scans"], "ate": s["ate_rmse"], "ate_max": s["ate_max"],
               "rpe_t": s["rpe_consecutive"]["trans_mean"], "rpe_t_std": s["rpe_consecutive"]["trans_std"],
               "rpe_r": s["rpe_consecutive"]["rot_mean_deg"], "rpe_r_std": s["rpe_consecutive"]["rot_std_deg"],
               "rpe1_t": s["rpe_1m"].get("trans_mean", float("nan")),
               "rpe1_r": s["rpe_1m"].get("rot_mean_deg", float("nan")),
               "rpe10_t": s["rpe_10m"].get("trans_mean", float("nan")),
               "rpe10_r": s["rpe_10m"].get("rot_mean_deg", float("nan")),
               "loops": rep["loop_closures"]["accepted"], "rejected": rep["loop_closures"]["rejected"],
               "ms": rep["ms_per_scan"], "cpu_ms": rep["cpu_ms_per_scan"], "rtf": rep["real_time_factor"],
               "odom_ate": o["ate_rmse"],
               "odom_rpe_r": o["rpe_consecutive"]["rot_mean_deg"], "missing_odom": rep["odometry_steps_missing"]}
        if not args.no_old and log.reference is not None:
            old = run_old(path)
            row.update(old_ate=old["ate"], old_rpe_r=old["rot_deg"], old_ms=old["ms"], old_loops=old["loops"])
        rows.append(row)
        print(json.dumps(row), flush=True)
        # Free this log's SLAM state before the next log runs, so the next log is not measured beside it in memory.
        del slam, log
        gc.collect()
    print(f"\noutputs in {out_root}\n")
    print("| log | scans | ATE m (max) | RPE consec. m / ° (mean ± std) | RPE 1 m: m / ° | RPE 10 m: m / ° "
          "| loops acc/rej | ms/scan CPU (wall) | RTF | odometry ATE m | odometry RPE ° | old pipeline ATE m |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        if r.get("no_reference"):
            print(f"| {r['log']} | {r['scans']} | no reference | – | – | – | {r['loops']}/{r['rejected']} "
                  f"| {r['cpu_ms']:.1f} ({r['ms']:.0f}) | – | – | – | – |")
            continue
        old_s = f"{r['old_ate']:.3f}" if "old_ate" in r else "–"
        rtf = f"{r['rtf']:.0f}×" if r["rtf"] else "–"
        print(f"| {r['log']} | {r['scans']} | {r['ate']:.3f} ({r['ate_max']:.2f}) | {r['rpe_t']:.3f} ± "
              f"{r['rpe_t_std']:.3f} / {r['rpe_r']:.2f} ± {r['rpe_r_std']:.2f} | {r['rpe1_t']:.3f} / {r['rpe1_r']:.2f} "
              f"| {r['rpe10_t']:.3f} / {r['rpe10_r']:.2f} | {r['loops']}/{r['rejected']} "
              f"| {r['cpu_ms']:.1f} ({r['ms']:.0f}) | {rtf} "
              f"| {r['odom_ate']:.2f} | {r['odom_rpe_r']:.2f} | {old_s} |")
    ates = [r["ate"] for r in rows if not r.get("no_reference")]
    if ates:
        print(f"\nmedian ATE {statistics.median(ates):.3f} m, worst {max(ates):.3f} m over {len(ates)} logs")
    print(f"CPU ms/scan per log {[round(r['cpu_ms'], 1) for r in rows]}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
