"""Batch missions: wall time and real-time factor of each shipped mission, and the speed-up of `-j 2`.

Baseline, measured in the same run: the same missions one after another in this process (`-j 1`). Then
the same set with two worker processes (`-j 2`, spawned: each worker pays its own imports). Runs are as
shipped (recording on), outputs in a temporary folder. The machine's other load shows up in the figures:
compare numbers from one invocation only.

    .venv/bin/python benchmarks/missions.py            # every mission in configs/missions
    .venv/bin/python benchmarks/missions.py --quick    # arena_navigation and coverage only
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from fleet.missions.batch import plan_runs, run_batch

MISSIONS = Path(__file__).resolve().parent.parent / "configs" / "missions"
QUICK = ("arena_navigation", "coverage")


def timed(files: list[str], out: Path, jobs: int) -> tuple[float, list]:
    t0 = time.perf_counter()
    outcomes = run_batch(plan_runs(files, out, None, 1), jobs=jobs, show_progress=False)
    return time.perf_counter() - t0, outcomes


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="two short missions only")
    args = ap.parse_args()
    files = sorted(str(p) for p in MISSIONS.glob("*.yaml") if not args.quick or p.stem in QUICK)
    print(f"{len(files)} missions, {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}")
    with tempfile.TemporaryDirectory() as tmp:
        seq_wall, seq = timed(files, Path(tmp) / "j1", 1)
        par_wall, par = timed(files, Path(tmp) / "j2", 2)
    print(f"\n{'mission':24s} {'result':6s} {'sim s':>7s} {'wall s':>7s} {'RTF':>6s}")
    for o in seq:
        print(f"{o.mission:24s} {'PASS' if o.passed else 'FAIL':6s} {o.report['end_time']:7.1f} {o.wall_s:7.2f} "
              f"{o.report['end_time'] / o.wall_s:6.1f}")
    sim = sum(o.report["end_time"] for o in seq)
    print(f"\n-j 1 (baseline): {seq_wall:6.1f} s wall for {sim:.0f} s of sim time (RTF {sim / seq_wall:.1f})")
    print(f"-j 2           : {par_wall:6.1f} s wall, speed-up ×{seq_wall / par_wall:.2f}")
    differ = [f"{a.mission} ({a.report['end_time']} s vs {b.report['end_time']} s)"
              for a, b in zip(seq, par, strict=True)
              if a.report["passed"] != b.report["passed"] or a.report["end_time"] != b.report["end_time"]]
    print(f"same verdicts and end times in both: {'yes' if not differ else 'no: ' + ', '.join(differ)}")


if __name__ == "__main__":
    main()
