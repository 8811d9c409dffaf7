"""Does recorded-log SLAM stay bounded per scan on long logs? Each CARMEN log in ../shared/data/carmen/ is played
`--passes` times back to back as ONE long log and mapped with the default config, beside a single pass of the
same log in the same process.

Long logs are built from the real data ("mirror", default): forward, then backward (the same scans in reverse
order: the robot drives the path back, odometry and reference poses read backwards, so both stay continuous),
then forward again, ... Every later pass revisits every place: the loop search, the pose graph and the
densification at the end see `passes`× the nodes and many more closures, which is what a 13k–17k scan log
(Intel, Killian Court) does. "repeat" replays the log forward every time; the step from the last scan to the
first of the next pass has no odometry (the robot is carried back), the front end's wide search must find it.
Stamps are shifted so they keep increasing.

Per chunk of `--chunk` scans: CPU ms/scan (the front end + loop search + iSAM2 while driving), of it the loop
search (candidates, verification; without the iSAM2 steps it triggers) and iSAM2 (update / converge), peak RSS
at the chunk's end; then finish() (iSAM2 convergence + densification) CPU, map size, and the final ATE against the
concatenated reference, beside the single pass's.

    nice -n 5 .venv/bin/python benchmarks/slam_scaling.py [--logs freiburg-079] [--passes 3] [--mode mirror]
                                                           [--chunk 1000] [--data DIR] [--no-single]
                                                           [--write DIR]
--write DIR only writes each long log as a CARMEN file DIR/<log>-x<passes>.log (FLASER poses = the reference,
ODOM = the odometry at each scan), e.g. for `fleetnav slam run` on it.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]

import argparse  # noqa: E402
import json  # noqa: E402
import resource  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402
from dataclasses import replace  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

from sim.config import load_yaml  # noqa: E402
from sim.types import Pose2D  # noqa: E402
from slam.io_carmen import format_flaser  # noqa: E402
from slam.log_config import LogSlamConfig  # noqa: E402
from slam.log_eval import evaluate  # noqa: E402
from slam.log_run import LoadedLog, load_log  # noqa: E402
from slam.log_slam import LogSlam  # noqa: E402
from slam.types import ScanRecord  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
# ../shared/data/carmen beside the checkout (a git worktree may sit one level deeper)
DATA = next((d / "shared" / "data" / "carmen" for d in ROOT.parents if (d / "shared" / "data" / "carmen").is_dir()),
            ROOT.parent / "shared" / "data" / "carmen")


def long_log(log: LoadedLog, passes: int, mode: str) -> LoadedLog:
    """`log` played `passes` times back to back (see the module doc)."""
    n = len(log.records)
    stamps = np.array([r.scan.stamp for r in log.records])
    span = float(stamps[-1] - stamps[0]) + 0.1 if n > 1 and stamps[-1] > stamps[0] else 0.0
    recs: list[ScanRecord] = []
    valid: list[bool] = []
    ref: list[np.ndarray] = []
    t_off = 0.0
    for p in range(passes):
        back = mode == "mirror" and p % 2 == 1
        order = list(range(n - 1, -1, -1)) if back else list(range(n))
        if p > 0 and mode == "mirror":
            order = order[1:]  # the turning scan is already there
        for m, k in enumerate(order):
            r = log.records[k]
            # a step's odometry validity belongs to its later scan: backwards, step k+1 -> k is step k -> k+1
            if back:
                ok = bool(log.odom_valid[k + 1]) if k + 1 < n else False
            else:
                ok = bool(log.odom_valid[k]) and not (mode == "repeat" and p > 0 and m == 0)
            t = stamps[0] + t_off + (stamps[-1] - stamps[k] if back else stamps[k] - stamps[0])
            recs.append(ScanRecord(replace(r.scan, stamp=float(t)), r.odom))
            valid.append(ok)
            if log.reference is not None:
                ref.append(log.reference[k])
        t_off += span
    return LoadedLog(recs, np.array(valid), np.array(ref) if ref else None, log.kind)


def write_carmen(log: LoadedLog, path: Path) -> None:
    assert log.reference is not None
    with path.open("w", encoding="utf-8") as f:
        f.write("# fleetnav benchmarks/slam_scaling.py: a real log played several times back to back\n")
        for k, rec in enumerate(log.records):
            t = rec.scan.stamp
            if rec.odom is not None and (k == 0 or log.odom_valid[k]):
                o = rec.odom
                f.write(f"ODOM {o.x:.6f} {o.y:.6f} {o.yaw:.6f} 0 0 0 {t:.6f} fleetnav {t:.6f}\n")
            ref = Pose2D(*(float(v) for v in log.reference[k]))
            f.write(format_flaser(rec.scan, ref, ref) + "\n")


class Clock:
    """CPU seconds spent in wrapped methods, per scan index (the method's own time minus nested wrapped calls)."""

    def __init__(self) -> None:
        self.scan = 0
        self.by: dict[str, dict[int, float]] = {}
        self._stack: list[float] = []

    def wrap(self, obj: object, name: str, label: str) -> None:
        fn: Callable[..., Any] = getattr(obj, name)
        acc = self.by.setdefault(label, {})

        def timed(*a: Any, **kw: Any) -> Any:
            c0 = time.process_time()
            self._stack.append(0.0)
            try:
                return fn(*a, **kw)
            finally:
                dt = time.process_time() - c0
                nested = self._stack.pop()
                acc[self.scan] = acc.get(self.scan, 0.0) + dt - nested
                if self._stack:
                    self._stack[-1] += dt

        setattr(obj, name, timed)

    def total(self, label: str, lo: int, hi: int) -> float:
        return sum(v for k, v in self.by.get(label, {}).items() if lo <= k < hi)


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def run(log: LoadedLog, cfg: LogSlamConfig, chunk: int, label: str) -> dict[str, Any]:
    slam = LogSlam(cfg)
    clock = Clock()
    clock.wrap(slam.loops, "step", "loops")
    for meth in ("update", "converge"):
        clock.wrap(slam.graph, meth, "isam2")
    n = len(log.records)
    rows = []
    deferred = [0]
    add = slam.loops.add

    def counting_add(*a: Any, **kw: Any) -> Any:
        before = len(slam.loops.deferred)
        out = add(*a, **kw)
        deferred[0] += len(slam.loops.deferred) > before
        return out

    slam.loops.add = counting_add  # type: ignore[method-assign]
    for k, rec in enumerate(log.records):
        clock.scan = k
        slam.add_scan(rec.scan, rec.odom, bool(log.odom_valid[k]),
                      lookahead=[r.scan for r in log.records[k + 1:k + 1 + cfg.lookahead.depth]])
        if (k + 1) % chunk == 0 or k == n - 1:
            lo = (k // chunk) * chunk
            m = k + 1 - lo
            row = {"scans": f"{lo}-{k}", "cpu_ms": 1000 * float(np.sum(slam.stats.cpu_times[lo:k + 1])) / m,
                   "loops_ms": 1000 * clock.total("loops", lo, k + 1) / m,
                   "isam2_ms": 1000 * clock.total("isam2", lo, k + 1) / m,
                   "closures": sum(c.accepted for c in slam.loops.history if lo <= c.source <= k),
                   "deferred_total": deferred[0],
                   "rss_mb": peak_rss_mb()}
            rows.append(row)
            print(label, json.dumps({k2: round(v, 2) if isinstance(v, float) else v for k2, v in row.items()}),
                  flush=True)
    clock.scan = n
    slam.finish()
    c0 = time.process_time()
    grid = slam.map()
    map_cpu = time.process_time() - c0
    out: dict[str, Any] = {"scans": n, "chunks": rows, "finish_cpu_s": slam.stats.finish_cpu,
                           "finish_isam2_s": clock.total("isam2", n, n + 1), "map_cpu_s": map_cpu,
                           "map_cells": list(grid.data.shape),
                           "cpu_ms": 1000 * (float(np.sum(slam.stats.cpu_times)) + slam.stats.finish_cpu) / n,
                           "accepted": slam.loops.accepted, "densified": slam.densifier.added,
                           "rss_mb": peak_rss_mb()}
    if log.reference is not None:
        out["ate"] = evaluate(np.array(slam.poses), log.reference)["ate_rmse"]
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--logs", default="freiburg-079", help="comma-separated log names (file name without "
                    "-corrected.log.gz) or paths")
    ap.add_argument("--data", type=Path, default=DATA)
    ap.add_argument("--passes", type=int, default=3)
    ap.add_argument("--mode", choices=("mirror", "repeat"), default="mirror")
    ap.add_argument("--chunk", type=int, default=1000)
    ap.add_argument("--no-single", action="store_true", help="skip the single-pass run")
    ap.add_argument("--config", type=Path, default=None, help="YAML with LogSlamConfig fields")
    ap.add_argument("--write", type=Path, default=None, help="only write the long logs (CARMEN) into this folder")
    args = ap.parse_args()
    if not args.data.is_dir():
        print(f"no data: {args.data} does not exist (the real logs live outside the repo); nothing measured")
        return 0
    cfg = load_yaml(args.config, LogSlamConfig) if args.config else LogSlamConfig()
    for name in args.logs.split(","):
        path = Path(name) if Path(name).is_file() else args.data / f"{name}-corrected.log.gz"
        if not path.is_file():
            print(f"no log {path}; skipped")
            continue
        base = load_log(path, cfg)
        if args.write is not None:
            args.write.mkdir(parents=True, exist_ok=True)
            write_carmen(long_log(base, args.passes, args.mode), args.write / f"{name}-x{args.passes}.log")
            print(f"wrote {args.write / f'{name}-x{args.passes}.log'}")
            continue
        res: dict[str, Any] = {"log": name, "passes": args.passes, "mode": args.mode}
        if not args.no_single:
            res["single"] = run(base, cfg, args.chunk, f"{name} x1")
        res["long"] = run(long_log(base, args.passes, args.mode), cfg, args.chunk, f"{name} x{args.passes}")
        print(json.dumps({k: v for k, v in res.items()}, default=float))
        lg = res["long"]
        first, last = lg["chunks"][0], lg["chunks"][-2] if len(lg["chunks"]) > 1 else lg["chunks"][-1]
        single = res.get("single", {})
        print(f"\n{name} ×{args.passes} ({args.mode}): {lg['scans']} scans, CPU {lg['cpu_ms']:.1f} ms/scan "
              f"(single {single.get('cpu_ms', float('nan')):.1f}); first chunk {first['cpu_ms']:.1f}, last full "
              f"chunk {last['cpu_ms']:.1f} ms/scan (×{last['cpu_ms'] / first['cpu_ms']:.2f}); finish "
              f"{lg['finish_cpu_s']:.1f} s (single {single.get('finish_cpu_s', float('nan')):.1f}); ATE "
              f"{lg.get('ate', float('nan')):.3f} m (single {single.get('ate', float('nan')):.3f}); peak RSS "
              f"{lg['rss_mb']:.0f} MB; map {lg['map_cells']} cells in {lg['map_cpu_s']:.1f} s\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
