"""BARN on the development worlds (../shared/data/barn: 50 real BARN worlds with their path files).

Per configuration, every world from (−2.25, 3, yaw 1.57) to (−2.25, 13) under BARN's rules (success within
1 m of the goal, no collision, < 100 s; metric success × T_opt / clip(T, 2·T_opt, 8·T_opt), T_opt from the
path file at 2.0 m/s). Configurations (one configuration for every world, no per-world tuning):
- sensors: barn_jackal, builtin:footprint_dwa, the map built from the robot's own lidar only;
- prior: the same navigator given the world's obstacles;
- diffbot: the course robot, lidar at 0.57 m over BARN's 0.5 m obstacles (it sees nothing), sensors only;
- diffbot_prior: the course robot with the prior map;
- diffbot_low: the course robot with its lidar mast shortened to put the lidar at 0.42 m, under the obstacles'
  tops (configs/robots/diffbot_low_lidar.yaml, a BARN variant), sensors only;
- baseline: the pre-existing planning.Navigator (circumscribed-disc inflation, prior map grown to
  cover the goal), barn_jackal — measured in the same run.
Reference figures (BARN paper, hidden test set): DWA 0.88 success / 0.169 metric; best 2023–24 entries ≈ 0.40–0.45.

    nice -n 10 .venv/bin/python benchmarks/barn.py                       # all 50 worlds, every configuration
    nice -n 10 .venv/bin/python benchmarks/barn.py --ids 3,99,243 --configs sensors,prior -j 2
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from fleet.grading.barn_suite import make_jobs, run_suite
from fleet.paths import robot_file
from sim.robot_spec import load_robot_spec

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT.parent / "shared" / "data" / "barn"
CONFIGS: dict[str, tuple[str, str, str]] = {  # name: (robot, controller, map_source)
    "sensors": ("barn_jackal", "builtin:footprint_dwa", "sensors"),
    "prior": ("barn_jackal", "builtin:footprint_dwa", "prior"),
    "diffbot": ("diffbot", "builtin:footprint_dwa", "sensors"),
    "diffbot_prior": ("diffbot", "builtin:footprint_dwa", "prior"),
    "diffbot_low": ("diffbot_low_lidar", "builtin:footprint_dwa", "sensors"),
    "baseline": ("barn_jackal", "builtin:navigator", "prior"),
}


def run_config(name: str, ids: list[int] | None, workers: int,
               out: Path) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    robot, controller, source = CONFIGS[name]
    spec = load_robot_spec(robot_file(robot))
    jobs = make_jobs(DATA, spec=spec, ids=ids, controller=controller, nav={"map_source": source})
    t0 = time.perf_counter()
    summary = run_suite(jobs, out / name, workers=workers)
    summary["wall_s_total"] = time.perf_counter() - t0
    rows = [json.loads(line) for line in (out / name / "results.jsonl").read_text().splitlines()]
    return summary, rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ids", default=None, help="comma-separated world ids (default: all)")
    ap.add_argument("--configs", default=",".join(CONFIGS), help=f"of {', '.join(CONFIGS)}")
    ap.add_argument("-j", type=int, default=1, help="worlds in parallel")
    ap.add_argument("--out", type=Path, default=Path("/tmp/barn_bench"))
    args = ap.parse_args()
    if not DATA.is_dir():
        print(f"BARN data not found at {DATA}: nothing to measure (see docs/benchmarks-navigation.md)")
        return
    ids = [int(t) for t in args.ids.split(",")] if args.ids else None
    names = [c for c in args.configs.split(",") if c]
    results = {n: run_config(n, ids, args.j, args.out) for n in names}
    print("## Summary (BARN metric; reference: DWA 0.88 / 0.169 on BARN's hidden test set)\n")
    print("| configuration | robot | controller | map | worlds | success | mean BARN metric | collisions | "
          "timeouts | mean T s (successes) | min clearance m | wall s/world (mean, max) |")
    print("|" + "---|" * 12)
    for n, (s, _) in results.items():
        robot, controller, source = CONFIGS[n]
        o = s["outcomes"]
        print(f"| {n} | {robot} | {controller} | {source} | {s['worlds']} | {s['success_rate']:.3f} | "
              f"{s['mean_barn_metric']:.3f} | {s['collisions']} | {o.get('timeout', 0)} | {s['mean_time_s']:.2f} | "
              f"{s['min_clearance']:.3f} | {s['wall_s_per_run']['mean']:.2f}, {s['wall_s_per_run']['max']:.2f} |")
    print("\n## Per world (outcome, T s, metric)\n")
    print("| world | T_opt s | " + " | ".join(names) + " |")
    print("|" + "---|" * (2 + len(names)))
    by = {n: {r["world_id"]: r for r in rows} for n, (_, rows) in results.items()}
    first = by[names[0]]
    for wid in sorted(first):
        cells = []
        for n in names:
            r = by[n].get(wid)
            cells.append("–" if r is None else f"{'ok' if r['success'] else r['outcome']} {r['time_s']:.1f} "
                         f"{r['barn_metric']:.3f}")
        print(f"| {wid} | {first[wid]['t_opt']:.2f} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
