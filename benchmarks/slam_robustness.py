"""Robustness sweep for SLAM on real logs: the default config (or --config) on perturbed copies of each CARMEN
log, as a proxy for logs it was not tuned on (other robots, scanners, odometry, rates).

Perturbations (seeded, applied to the loaded log; the reference poses are kept, or thinned with the scans):
  base     the log as it is
  drop2    every 2nd scan dropped (half the rate: twice the motion between scans)
  odom     extra odometry noise: each increment gets N(0, 0.02 m + 2 % of its length) per axis and
           N(0, 0.5° + 3 % of its turn) in heading, so the chain drifts more than the real one
  range    extra range noise N(0, 0.03 m) on every return
  beams2   every 2nd beam dropped (half the angular resolution)
  noodom   no odometry at all (like orebro everywhere)
  yawbias  a heading bias of 2° per metre driven added to the odometry (a wheel-diameter mismatch): the raw
           chain curls up; with it, `loop_off` reports how far each accepted closure moved its scan from the
           estimate (the drift it closed) and the path back to its submap

Per log × perturbation: ATE RMSE against the reference, closures in the final graph and how many of them
are wrong (their relative pose > 0.3 m or 2° from the reference's), split into coverage closures
(`slam.loop_coverage`) and the usual ones, and CPU ms/scan. A closure is compared in its anchor's frame, so a
match on geometry far from the anchor also carries the estimate's drift inside the submap (see
docs/benchmarks-slam.md, helper 14e): "wrong" is a flag to look at, not a verdict. The default set of four
perturbations takes about 5 min of CPU (freiburg-079 is 3/4 of it); add base and noodom for the full table.

    nice -n 5 .venv/bin/python benchmarks/slam_robustness.py [--logs edmonton,...] [--perturb base,drop2,...]
                                                              [--config FILE] [--json OUT]
"""

from __future__ import annotations

import sys
from pathlib import Path

# Run as a script, this file's folder comes first on sys.path and its name would shadow the slam package.
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # `benchmarks.slam_real` without PYTHONPATH

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

from benchmarks._blackout import blackout, gap_report  # noqa: E402
from benchmarks.slam_real import DATA, find_logs, log_name  # noqa: E402
from sim.config import load_yaml  # noqa: E402
from sim.transforms import se2_between, se2_compose  # noqa: E402
from sim.types import Pose2D  # noqa: E402
from slam.log_config import LogSlamConfig  # noqa: E402
from slam.log_eval import evaluate  # noqa: E402
from slam.log_loops import Submap  # noqa: E402
from slam.log_run import LoadedLog, load_log, run_slam  # noqa: E402
from slam.types import ScanRecord  # noqa: E402

WRONG_M, WRONG_DEG = 0.3, 2.0


def _drop2(log: LoadedLog, rng: np.random.Generator) -> LoadedLog:
    ref = log.reference[::2] if log.reference is not None else None
    rates = log.odom_rates[::2] if log.odom_rates is not None else None
    return dataclasses.replace(log, records=log.records[::2], odom_valid=log.odom_valid[::2], reference=ref,
                               odom_rates=rates)


def _odom(log: LoadedLog, rng: np.random.Generator) -> LoadedLog:
    """Re-chain the odometry from noisier increments (only between steps that have odometry)."""
    recs = list(log.records)
    prev_raw: tuple[float, float, float] | None = None
    prev_new: tuple[float, float, float] | None = None
    for k, r in enumerate(recs):
        if r.odom is None or not log.odom_valid[k] or prev_raw is None or prev_new is None:
            prev_raw = r.odom.as_tuple() if r.odom is not None else None
            prev_new = prev_raw
            continue
        raw = r.odom.as_tuple()
        dx, dy, dt = se2_between(prev_raw, raw)
        length = math.hypot(dx, dy)
        s_xy, s_t = 0.02 + 0.02 * length, math.radians(0.5) + 0.03 * abs(dt)
        inc = (dx + rng.normal(0, s_xy), dy + rng.normal(0, s_xy), dt + rng.normal(0, s_t))
        new = se2_compose(prev_new, inc)
        recs[k] = ScanRecord(r.scan, Pose2D(*new))
        prev_raw, prev_new = raw, new
    return dataclasses.replace(log, records=recs)  # the ODOM rates (deskew's turn rate) keep their own noise


def _range(log: LoadedLog, rng: np.random.Generator) -> LoadedLog:
    recs = []
    for r in log.records:
        ranges = r.scan.ranges + rng.normal(0, 0.03, r.scan.ranges.shape)  # inf stays inf
        ranges = np.where(ranges < r.scan.range_min, np.inf, ranges)
        recs.append(ScanRecord(dataclasses.replace(r.scan, ranges=ranges), r.odom))
    return dataclasses.replace(log, records=recs)


def _beams2(log: LoadedLog, rng: np.random.Generator) -> LoadedLog:
    recs = [ScanRecord(dataclasses.replace(r.scan, ranges=r.scan.ranges[::2].copy(),
                                           angle_increment=2 * r.scan.angle_increment,
                                           hit_bodies=None), r.odom) for r in log.records]
    return dataclasses.replace(log, records=recs)


def _yawbias(log: LoadedLog, rng: np.random.Generator, deg_per_m: float = 2.0) -> LoadedLog:
    """Re-chain the odometry with every increment turned by `deg_per_m` per metre of its length."""
    recs = list(log.records)
    prev_raw: tuple[float, float, float] | None = None
    prev_new: tuple[float, float, float] | None = None
    for k, r in enumerate(recs):
        if r.odom is None or prev_raw is None or prev_new is None:
            prev_raw = prev_new = r.odom.as_tuple() if r.odom is not None else None
            continue
        raw = r.odom.as_tuple()
        dx, dy, dt = se2_between(prev_raw, raw)
        new = se2_compose(prev_new, (dx, dy, dt + math.radians(deg_per_m) * math.hypot(dx, dy)))
        recs[k] = ScanRecord(r.scan, Pose2D(*new))
        prev_raw, prev_new = raw, new
    rates = None
    if log.odom_rates is not None:  # the same bias in the turn rate: ω + bias · speed
        rates = log.odom_rates.copy()
        rates[:, 2] += math.radians(deg_per_m) * np.hypot(rates[:, 0], rates[:, 1])
    return dataclasses.replace(log, records=recs, odom_rates=rates)


def _noodom(log: LoadedLog, rng: np.random.Generator) -> LoadedLog:
    return dataclasses.replace(log, odom_valid=np.zeros_like(log.odom_valid), odom_rates=None)


PERTURB: dict[str, Callable[[LoadedLog, np.random.Generator], LoadedLog]] = {
    "base": lambda log, rng: log, "drop2": _drop2, "odom": _odom, "range": _range, "beams2": _beams2,
    "noodom": _noodom, "yawbias": _yawbias, "blackout": lambda log, rng: blackout(log, rng)[0]}


def run_one(log: LoadedLog, cfg: LogSlamConfig, spans: list[tuple[int, int]] | None = None) -> dict[str, Any]:
    """Run SLAM; ATE, CPU, and the final graph's closures checked against the reference relative poses."""
    from slam import log_loops

    coverage_pairs: set[tuple[int, int]] = set()
    orig_verify = log_loops.LoopFinder.verify

    def verify(self: log_loops.LoopFinder, i: int, sm: Submap, radius: float, yaw: float | None = None
               ) -> log_loops.Closure:
        if sm.coverage is not None:  # measurement only: remember which pairs came from coverage candidates
            coverage_pairs.add((i, sm.anchor))
        return orig_verify(self, i, sm, radius, yaw)

    offs: list[tuple[float, float]] = []  # (correction m, path back to the submap m) of each accepted closure
    orig_add = log_loops.LoopFinder.add

    def add(self: log_loops.LoopFinder, target: int, source: int, relative: tuple[float, float, float],
            *a: Any, **kw: Any) -> log_loops.Closure:
        now = se2_compose(self.slam.poses[target], relative)
        off = math.hypot(now[0] - self.slam.poses[source][0], now[1] - self.slam.poses[source][1])
        c = orig_add(self, target, source, relative, *a, **kw)
        if c.accepted:
            offs.append((off, self.slam.path[source] - self.slam.path[target]))
        return c

    log_loops.LoopFinder.verify = verify  # type: ignore[method-assign]
    log_loops.LoopFinder.add = add  # type: ignore[method-assign]
    try:
        t0 = time.perf_counter()
        slam = run_slam(log, cfg)
        wall = time.perf_counter() - t0
    finally:
        log_loops.LoopFinder.verify = orig_verify  # type: ignore[method-assign]
        log_loops.LoopFinder.add = orig_add  # type: ignore[method-assign]
    _, est = slam.trajectory()
    n = len(est)
    assert log.reference is not None and len(log.reference) == n
    ref = log.reference
    metrics: dict[str, Any] = evaluate(est, ref)
    row: dict[str, Any] = {"scans": n, "ate": float(metrics["ate_rmse"]),
                           "cpu_ms": 1000 * (float(np.sum(slam.stats.cpu_times)) + slam.stats.finish_cpu) / max(n, 1),
                           "wall_s": wall}
    counts = {"cov": 0, "cov_wrong": 0, "usual": 0, "usual_wrong": 0}
    worst: list[tuple[float, int, int]] = []
    for c in slam.loops.active.values():
        e = se2_between(se2_between(tuple(ref[c.target]), tuple(ref[c.source])), c.relative)
        err_m, err_deg = math.hypot(e[0], e[1]), abs(math.degrees(e[2]))
        kind = "cov" if (c.source, c.target) in coverage_pairs else "usual"
        counts[kind] += 1
        if err_m > WRONG_M or err_deg > WRONG_DEG:
            counts[kind + "_wrong"] += 1
            worst.append((err_m, c.source, c.target))
    row.update(counts)
    big = sorted(offs, reverse=True)
    row["loop_off"] = {"max_m": round(big[0][0], 2) if big else 0.0,
                       "over_0.5m": sum(o > 0.5 for o, _ in big), "over_1m": sum(o > 1.0 for o, _ in big),
                       "largest": [f"{o:.2f}m after {d:.0f}m" for o, d in big[:3]]}
    row["wrong"] = [f"{s}->{t}:{m:.2f}m" for m, s, t in sorted(worst, reverse=True)[:4]]
    if spans is not None:
        row["gaps"] = gap_report(log, spans, est)
    return row


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--logs", default=None, help="comma-separated log names or paths (default: every log in --data)")
    ap.add_argument("--data", type=Path, default=DATA if DATA.is_dir() else Path("/work/shared/data/carmen"))
    ap.add_argument("--perturb", default="drop2,odom,range,beams2",
                    help=f"comma-separated, of {', '.join(PERTURB)} (default: the four that fit ~10 min on 2 cores)")
    ap.add_argument("--config", type=Path, default=None, help="YAML with LogSlamConfig fields")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", type=Path, default=None, help="also write the rows here")
    args = ap.parse_args()
    paths = find_logs(args.data, args.logs)
    if not paths:
        print(f"no data: no CARMEN logs in {args.data}; nothing measured")
        return 0
    kinds = args.perturb.split(",")
    rows = []
    t_start = time.perf_counter()
    for path in paths:
        cfg = load_yaml(args.config, LogSlamConfig) if args.config else LogSlamConfig()
        base = load_log(path, cfg)
        if base.reference is None:
            continue
        for kind in kinds:
            rng = np.random.default_rng(args.seed)
            log, spans = blackout(base, rng) if kind == "blackout" else (PERTURB[kind](base, rng), None)
            row = {"log": log_name(path), "perturb": kind, **run_one(log, cfg, spans)}
            rows.append(row)
            print(json.dumps(row), flush=True)
    print(f"\n{time.perf_counter() - t_start:.0f} s wall\n")
    logs = list(dict.fromkeys(r["log"] for r in rows))
    print("ATE m (wrong closures in the final graph: coverage + usual)\n")
    print("| log | " + " | ".join(kinds) + " |")
    print("|---|" + "---|" * len(kinds))
    by = {(r["log"], r["perturb"]): r for r in rows}
    for name in logs:
        cells = []
        for kind in kinds:
            r = by.get((name, kind))
            cells.append("–" if r is None else f"{r['ate']:.3f} ({r['cov_wrong']}+{r['usual_wrong']})")
        print(f"| {name} | " + " | ".join(cells) + " |")
    for kind in kinds:
        ates = [by[(n, kind)]["ate"] for n in logs if (n, kind) in by]
        if ates:
            print(f"{kind}: median {statistics.median(ates):.3f} m, worst {max(ates):.3f} m, "
                  f"CPU ms/scan max {max(by[(n, kind)]['cpu_ms'] for n in logs if (n, kind) in by):.1f}")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1), encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
