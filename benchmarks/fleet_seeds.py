"""The traffic layer's 300-robot warehouse over many seeds at once: one row per seed and the aggregate a change to
the layer should be judged on.

One run's longest wait moves by ±20 s with any perturbation of the layer (docs/benchmarks-fleet.md), so a change
judged on a few seeds' longest waits is judged on noise. Reported here, per seed and summed: the seeds on which
every wait (closed, and still open at the end) stayed within `--bound`, and the waits over 20 / 25 / 30 s (the
tail's mass, much steadier than its maximum), beside tasks/min and the independent collision check of
`benchmarks/fleet.py --traffic` (`_fleet_traffic.run_traffic`, the same run). Seeds run in `--jobs` worker
processes; with the lidar off the layer takes the same decisions as with it on (its robots never read the
lidar: every row of the tenth landing's table repeats to the digit), at about a third of the wall time.
Each seed's 2× ORCA bar is `fleet.py --robots N --minutes M --avoidance orca --seed S` (4–5 min per seed at 300).

    cd benchmarks && nice -n 5 ../.venv/bin/python fleet_seeds.py --seeds 0-11 --jobs 2      # development seeds
    cd benchmarks && nice -n 5 ../.venv/bin/python fleet_seeds.py --seeds 12-17 --minutes 5  # held out, longer

`--json FILE` writes each seed's row as a JSON line; `compare_seeds.py NEW BASE` judges two such runs seed by seed
(a paired sign test: one set's sums can point either way).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import multiprocessing as mp
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.append(str(HERE))

from _fleet_traffic import seconds_or_off  # noqa: E402 (after the path set-up)
from compare_seeds import longest_wait  # noqa: E402

from fleet.traffic.admission import ADMISSION  # noqa: E402

COLUMNS = ("seed", "done_per_min", "robot_collisions", "obstacle_hits", "failed", "deadlocks", "waits_over_20_s",
           "waits_over_25_s", "waits_over_30_s", "longest_deadlock_s", "longest_open_s", "cycle_waits",
           "admission_limit", "lowest_limit", "latency_p95_s", "rtf", "load")


def parse_seeds(text: str) -> list[int]:
    """'0-11', '0,3,9' or '0-3,12' -> the seeds, in order."""
    out: list[int] = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out.extend(range(int(lo), int(hi or lo) + 1))
    return out


def one_seed(args: tuple[int, int, float, str, str, int, bool, float, bool, float | None]) -> dict[str, Any]:
    """One run in a worker process (its own world)."""
    seed, robots, minutes, lidar, admission, urgent_window, keep_clear, keep_clear_s, held_clear, hold_ground_s = args
    spec = importlib.util.spec_from_file_location("fleet_bench", HERE / "fleet.py")  # not `fleet`: the package
    assert spec is not None and spec.loader is not None
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    from _fleet_traffic import run_traffic

    with tempfile.TemporaryDirectory() as tmp:
        model = bench.robot_model(Path(tmp), bench.LIDAR_FULL if lidar == "on" else bench.LIDAR_OFF, f"d_{lidar}.yaml")
        r = run_traffic(robots, minutes, seed, model, admission=admission, urgent_window=urgent_window,
                        keep_clear=keep_clear, keep_clear_s=keep_clear_s, held_clear=held_clear,
                        hold_ground_s=hold_ground_s,
                        lidar="360 beams 10 Hz" if lidar == "on" else "off")
    return {"seed": seed, **r}


def json_row(r: dict[str, Any]) -> dict[str, Any]:
    """A seed's row as plain JSON values: numbers (numpy scalars as Python's) and strings; the rest left out."""
    out: dict[str, Any] = {}
    for k, v in r.items():
        v = v.item() if getattr(v, "shape", None) == () else v
        if isinstance(v, int | float | str):
            out[k] = v
    return out


def within(r: dict[str, Any], bound: float) -> bool:
    return longest_wait(r) <= bound


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", default="0-11", help="e.g. 0-11, 0,3,9 or 0-3,12 (default 0-11)")
    ap.add_argument("--robots", type=int, default=300)
    ap.add_argument("--minutes", type=float, default=2.0)
    ap.add_argument("--lidar", choices=("on", "off"), default="off", help="off: the same decisions, ~3× faster")
    ap.add_argument("--admission", choices=ADMISSION, default="bound")
    ap.add_argument("--urgent-window", type=int, default=1,
                    help="moves an urgent robot may have planned ahead (default 1: the layer's `window`)")
    ap.add_argument("--keep-clear", choices=("on", "off"), default="on",
                    help="robots enter a crossing of aisles only with a way out, or after --keep-clear-s at rest "
                         "(traffic/crossings.py; default on)")
    ap.add_argument("--keep-clear-s", type=float, default=4.0,
                    help="a robot kept out of a crossing this long at rest enters anyway (default 4)")
    ap.add_argument("--held-clear", choices=("on", "off"), default="on",
                    help="robots whose goals are held plan no move of their own into the way of a robot in a wait "
                         "(traffic/admission_wait.py; default on)")
    ap.add_argument("--hold-ground-s", type=seconds_or_off, default=5.0,
                    help="a robot with a goal that has not come closer for this long is not pushed back until it is "
                         "urgent (traffic/priority.py; default 5; off: PIBT's pushes)")
    ap.add_argument("--bound", type=float, default=30.0, help="the wait bound, s (issue 17: 30)")
    ap.add_argument("--jobs", type=int, default=2, help="worker processes")
    ap.add_argument("--json", type=Path, default=None,
                    help="also write each seed's row to this file as a JSON line (for compare_seeds.py)")
    a = ap.parse_args()
    seeds = parse_seeds(a.seeds)
    print(f"warehouse.world, {a.robots} robots, {a.minutes:g} sim-minutes, lidar {a.lidar}, admission "
          f"{a.admission}, urgent_window {a.urgent_window}, keep_clear {a.keep_clear} ({a.keep_clear_s:g} s), "
          f"held_clear {a.held_clear}, hold_ground_s {a.hold_ground_s}, seeds {a.seeds}, {a.jobs} worker processes")
    print(" | ".join(COLUMNS))
    rows: list[dict[str, Any]] = []
    if a.json is not None:
        a.json.write_text("")  # this run's rows only
    jobs = [(s, a.robots, a.minutes, a.lidar, a.admission, a.urgent_window, a.keep_clear == "on",
             a.keep_clear_s, a.held_clear == "on", a.hold_ground_s) for s in seeds]
    with ProcessPoolExecutor(max_workers=a.jobs, mp_context=mp.get_context("spawn")) as pool:
        for r in pool.map(one_seed, jobs):
            rows.append(r)
            if a.json is not None:
                with a.json.open("a") as out:
                    out.write(json.dumps(json_row(r)) + "\n")
            print(" | ".join(f"{r[c]:.2f}" if isinstance(r[c], float) else str(r[c]) for c in COLUMNS), flush=True)
    n = len(rows)
    total = lambda key: sum(r[key] for r in rows)  # noqa: E731
    print(f"seeds with every wait within {a.bound:g} s: {sum(within(r, a.bound) for r in rows)} of {n}; "
          f"mean {total('done_per_min') / n:.1f} tasks/min; waits over 20 / 25 / 30 s: {total('waits_over_20_s')} / "
          f"{total('waits_over_25_s')} / {total('waits_over_30_s')} of {total('deadlocks')}; collisions "
          f"{total('robot_collisions')} / {total('obstacle_hits')}; failed {total('failed')}; cycle waits "
          f"{total('cycle_waits')}")


if __name__ == "__main__":
    main()
