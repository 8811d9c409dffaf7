"""Sweeps: the same N mission runs (missions × seeds, recording on) with the local executor at `-j 1` (the
baseline, in this process), `-j 2` (a local pool of two worker processes), and a Ray cluster of two worker
processes started with `ray start --head --num-cpus=2` on 127.0.0.1 (cluster start-up not counted; connecting
is). Prints wall time, speed-up vs `-j 1`, and the executor's overhead per run:

    overhead per run = (sweep wall × worker slots − Σ run wall measured inside the workers) / N

i.e. the time a worker slot spent not running a mission (scheduling, pickling, shipping the run's files back,
writing them, idle tail). Also checks that the three sweeps wrote identical files (wall-clock fields aside).
The load average is printed beside each figure: on a shared machine, compare figures of one invocation only.

    nice -n 10 .venv/bin/python benchmarks/sweep.py                 # 40 runs: arena_navigation + coverage × 20 seeds
    nice -n 10 .venv/bin/python benchmarks/sweep.py --runs 8        # a quick look
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from fleet.executors.ray_local import LOOPBACK_ENV

os.environ.update(LOOPBACK_ENV)  # before Ray is imported

from fleet.executors import InlineExecutor, JobResult, JobState, PoolExecutor
from fleet.missions.batch import PRELOAD, as_outcome, mission_jobs, plan_runs, write_batch_outputs
from fleet.missions.report import comparable

MISSIONS = Path(__file__).resolve().parent.parent / "configs" / "missions"
SWEEP = ("arena_navigation", "coverage")


def sweep(name: str, executor, reqs, out: Path, slots: int) -> dict:
    load0 = os.getloadavg()[0]
    t0 = time.perf_counter()
    results: list[JobResult] = executor.run(mission_jobs(reqs))
    wall = time.perf_counter() - t0
    write_batch_outputs([as_outcome(reqs[r.index], r) for r in results], out)
    busy = sum(r.wall_s for r in results)
    ok = sum(r.state is JobState.DONE and r.value.passed for r in results)
    row = {"executor": name, "runs": len(results), "passed": ok, "wall_s": wall, "slots": slots,
           "mean_run_s": busy / len(results), "overhead_per_run_s": (wall * slots - busy) / len(results),
           "load_before": load0, "load_after": os.getloadavg()[0]}
    print(f"{name:22s} wall {wall:7.1f} s  mean run {row['mean_run_s']:5.2f} s  overhead/run "
          f"{row['overhead_per_run_s']:5.2f} s  passed {ok}/{len(results)}  load {load0:.1f}→{row['load_after']:.1f}",
          flush=True)
    return row


def files(root: Path) -> dict[str, bytes]:
    out = {}
    for p in sorted(root.rglob("*")):
        if p.is_file() and p.name != "report.md":
            data = p.read_bytes()
            if p.name == "report.json":
                data = json.dumps(comparable(json.loads(data))).encode()
            elif p.name == "junit.xml":
                data = re.sub(rb' time="[0-9.]+"', b"", data)
            out[p.relative_to(root).as_posix()] = data
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=40, help="total runs (split evenly over the missions)")
    ap.add_argument("--no-ray", action="store_true", help="local executors only")
    ap.add_argument("--reverse", action="store_true", help="Ray first, then -j 2, then -j 1 (load drifts on a "
                    "shared machine: run both orders)")
    args = ap.parse_args()
    paths = [str(MISSIONS / f"{m}.yaml") for m in SWEEP]
    per = max(1, args.runs // len(paths))
    print(f"{per * len(paths)} runs ({', '.join(SWEEP)} × {per} seeds), {os.cpu_count()} CPUs, "
          f"load average {os.getloadavg()}", flush=True)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        roots = {}

        def plan(name: str):
            roots[name] = Path(tmp) / name
            return plan_runs(paths, roots[name], 100, per)

        def local(name: str) -> None:
            if name == "j1":
                rows.append(sweep("local -j 1", InlineExecutor(), plan("j1"), roots["j1"], 1))
            else:
                rows.append(sweep("local -j 2", PoolExecutor(2, preload=PRELOAD), plan("j2"), roots["j2"], 2))

        def on_ray() -> None:
            from fleet.executors.ray_exec import RayExecutor
            from fleet.executors.ray_local import local_cluster

            with local_cluster(cpus=2, connect=False) as address:
                t0 = time.perf_counter()
                ex = RayExecutor(address)
                ray, _ = ex.connect()
                connect_s = time.perf_counter() - t0
                print(f"ray: connected to {address} in {connect_s:.2f} s", flush=True)
                rows.append(sweep("ray, 2 workers", ex, plan("ray"), roots["ray"], 2) | {"connect_s": connect_s})
                ray.shutdown()

        steps = [lambda: local("j1"), lambda: local("j2")] + ([] if args.no_ray else [on_ray])
        for step in reversed(steps) if args.reverse else steps:
            step()
        rows.sort(key=lambda r: ["local -j 1", "local -j 2", "ray, 2 workers"].index(r["executor"]))
        base = files(roots["j1"])
        for name in roots:
            same = files(roots[name]) == base
            print(f"{name}: files identical to -j 1: {same}")
    j1 = rows[0]["wall_s"]
    print("\n| executor | runs | wall s | speed-up vs -j 1 | mean run s | overhead/run s | load avg (1 min) |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['executor']} | {r['runs']} | {r['wall_s']:.1f} | ×{j1 / r['wall_s']:.2f} | "
              f"{r['mean_run_s']:.2f} | {r['overhead_per_run_s']:.2f} | {r['load_before']:.1f}→{r['load_after']:.1f} |")
    if len(rows) == 3:
        print(f"\nRay overhead per run minus local -j 2 overhead per run: "
              f"{rows[2]['overhead_per_run_s'] - rows[1]['overhead_per_run_s']:+.2f} s (target ≤ 0.5 s)")


if __name__ == "__main__":
    main()
