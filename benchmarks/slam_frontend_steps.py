"""Which front-end steps of a (perturbed) real log go wrong, and how the look-ahead decided them.

Runs the default config (or --config) on one CARMEN log with one perturbation of `benchmarks/slam_robustness.py`
and lists every consecutive front-end edge more than 0.25 m / 3° from the reference step, then every look-ahead
decision (`slam.lookahead.choose`): for each hypothesis its distance from the reference pose (given the previous
estimated pose), its own objective, the next scans' objectives, the free-space penalty and the total.
`--oracle` makes every look-ahead take the hypothesis nearest the reference (measurement only: how much of the
error the look-ahead's choices explain).

    nice -n 5 .venv/bin/python benchmarks/slam_frontend_steps.py orebro --perturb range [--oracle] [--config F]
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import argparse
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from benchmarks.slam_real import DATA, find_logs
from benchmarks.slam_robustness import PERTURB
from sim.config import load_yaml
from sim.transforms import se2_between, se2_compose
from slam import log_slam, lookahead
from slam.csm import CsmResult
from slam.log_config import LogSlamConfig
from slam.log_eval import evaluate
from slam.log_run import load_log, run_slam

Pose = tuple[float, float, float]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("log", help="log name in --data (e.g. orebro) or a path")
    ap.add_argument("--data", type=Path, default=DATA if DATA.is_dir() else Path("/work/shared/data/carmen"))
    ap.add_argument("--perturb", default="base", choices=sorted(PERTURB))
    ap.add_argument("--config", help="YAML with LogSlamConfig fields")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--oracle", action="store_true", help="look-ahead takes the hypothesis nearest the reference")
    args = ap.parse_args()
    cfg = load_yaml(args.config, LogSlamConfig) if args.config else LogSlamConfig()
    (path,) = find_logs(args.data, args.log)
    log = PERTURB[args.perturb](load_log(path, cfg), np.random.default_rng(args.seed))
    ref = log.reference
    assert ref is not None
    node = {"i": 0}
    decisions: dict[int, list[tuple[float, list[Any], float, bool]]] = {}
    orig_add, orig_choose = log_slam.LogSlam.add_scan, lookahead.choose

    def add_scan(self: log_slam.LogSlam, *a: Any, **k: Any) -> Any:
        node["i"] = len(self.poses)
        return orig_add(self, *a, **k)

    def choose(hyps: Sequence[CsmResult], prev: Pose, points: np.ndarray, following: Any, grid_of: Any,
               wide: Any, penalty: Callable[[Any], float] | None = None) -> tuple[CsmResult, list[float]]:
        i = node["i"]
        truth = se2_compose(prev, se2_between(tuple(ref[i - 1]), tuple(ref[i])))
        rows = []
        for h in hyps:  # each hypothesis alone, recording its parts (choose sums them the same way)
            parts: list[Any] = [round(float(h.score), 3)]

            def rec_wide(g: Any, p: np.ndarray, guess: Pose, parts: list[Any] = parts) -> CsmResult | None:
                r: CsmResult | None = wide(g, p, guess)
                parts.append(None if r is None else round(r.score, 3))
                return r

            def rec_pen(chain: Any, parts: list[Any] = parts) -> float:
                v = penalty(chain) if penalty is not None else 0.0
                parts.append(f"fs {v:.3f}")
                return v

            _, (total,) = orig_choose([h], prev, points, following, grid_of, rec_wide, rec_pen)
            off = math.hypot(h.pose[0] - truth[0], h.pose[1] - truth[1]) + abs(math.remainder(
                h.pose[2] - truth[2], math.tau))
            rows.append((round(off, 2), parts, round(total, 3)))
        best, totals = orig_choose(hyps, prev, points, following, grid_of, wide, penalty)
        if args.oracle:
            best = hyps[int(np.argmin([r[0] for r in rows]))]
        decisions[i] = [(*r, h is best) for r, h in zip(rows, hyps, strict=True)]
        return best, totals

    log_slam.LogSlam.add_scan = add_scan  # type: ignore[method-assign]
    log_slam.choose = choose  # type: ignore[assignment]
    slam = run_slam(log, cfg)
    ev: dict[str, Any] = evaluate(np.array(slam.poses), ref)
    pts = [len(p) for p in slam.points]
    print(f"{args.log} {args.perturb}{' oracle' if args.oracle else ''}: ATE {float(ev['ate_rmse']):.3f} m, "
          f"wide {slam.stats.wide}, odometry-only {slam.stats.odometry_only}, look-aheads {slam.stats.lookahead} "
          f"(switched {slam.stats.lookahead_switched}), thinned points median {np.median(pts):.0f} "
          f"(min {min(pts)}, < loops.min_points: {sum(n < cfg.loops.min_points for n in pts)})")
    print("front-end steps off the reference (step, m, deg):")
    for a, b, rel, _ in slam.edges:
        if b != a + 1:
            continue
        t = se2_between(tuple(ref[a]), tuple(ref[b]))
        e, ey = math.hypot(rel[0] - t[0], rel[1] - t[1]), math.degrees(abs(math.remainder(rel[2] - t[2], math.tau)))
        if e > 0.25 or ey > 3.0:
            print(f"  {b}: {e:.2f} m {ey:.1f}°")
    print("look-ahead decisions: step: (off the reference m+rad, [own, next scans…, free-space], total, chosen)")
    for i, rows in sorted(decisions.items()):
        print(f"  {i}: " + "  ".join(f"({o}, {p}, {t}{', *' if c else ''})" for o, p, t, c in rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
