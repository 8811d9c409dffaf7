"""Two runs of `fleet_seeds.py --json` compared seed by seed: is a change to the traffic layer better than the noise?

The warehouse's long waits are rare and overdispersed per seed (at 300 robots the waits over 25 s per seed have mean
0.89 and variance 2.35; two sets of 32 seeds gave 14 and 40 with the same code, docs/benchmarks-fleet.md, twenty-first
landing), so a change's sums over one set of seeds can point either way. Here, on the seeds both runs have: the sums
of each, and per figure a paired sign test (on how many seeds the new run is lower, higher, equal; exact two-sided
binomial p over the seeds that differ). A change worth keeping shows on the paired test, not only on one set's sums.

    cd benchmarks && ../.venv/bin/python fleet_seeds.py --seeds 0-31 --minutes 10 --json /tmp/base.jsonl
    cd benchmarks && ../.venv/bin/python fleet_seeds.py --seeds 0-31 --minutes 10 --hold-ground-s off \
        --json /tmp/new.jsonl
    cd benchmarks && ../.venv/bin/python compare_seeds.py /tmp/new.jsonl /tmp/base.jsonl
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
from pathlib import Path
from typing import Any

FIGURES = ("waits_over_20_s", "waits_over_25_s", "waits_over_30_s", "longest_wait_s")  # lower is better
NEEDED = ("seed", "done_per_min", "waits_over_20_s", "waits_over_25_s", "waits_over_30_s", "longest_deadlock_s",
          "longest_open_s", "cycle_waits")


def longest_wait(row: dict[str, Any]) -> float:
    """A run's longest wait: the longer of the closed waits' and the one still open at the end."""
    return float(max(row["longest_deadlock_s"], row["longest_open_s"]))


def load(path: Path) -> dict[int, dict[str, Any]]:
    """Seed -> row, from a JSON-lines file (one object per seed). A bad line is named with its file and line."""
    rows: dict[int, dict[str, Any]] = {}
    for n, line in enumerate(path.read_text().splitlines(), 1):
        if not line.strip():
            continue
        try:
            row = json.loads(line)
        except json.JSONDecodeError as e:
            raise ValueError(f"{path}:{n}: not JSON ({e.msg})") from None
        missing = [k for k in NEEDED if not isinstance(row, dict) or k not in row]
        if missing:
            raise ValueError(f"{path}:{n}: missing {', '.join(missing)} (write it with fleet_seeds.py --json)")
        row["longest_wait_s"] = longest_wait(row)
        rows[int(row["seed"])] = row
    return rows


def sign_test(lower: int, higher: int) -> float:
    """Exact two-sided p of a sign test: `lower` and `higher` counts of the seeds that differ (ties dropped)."""
    n = lower + higher
    if n == 0:
        return 1.0
    tail = sum(math.comb(n, k) for k in range(min(lower, higher) + 1)) / 2**n
    return min(1.0, 2.0 * tail)


def paired(new: dict[int, dict[str, Any]], base: dict[int, dict[str, Any]], key: str) -> tuple[int, int, int, float]:
    """On the seeds both have: how often `new` is lower, higher and equal in `key`, and the sign test's p."""
    seeds = sorted(new.keys() & base.keys())
    lower = sum(new[s][key] < base[s][key] for s in seeds)
    higher = sum(new[s][key] > base[s][key] for s in seeds)
    return lower, higher, len(seeds) - lower - higher, sign_test(lower, higher)


def sums(rows: dict[int, dict[str, Any]], seeds: list[int], bound: float) -> str:
    """One run's sums over `seeds`, and the spread per seed of its waits over 25 s."""
    over = " / ".join(str(sum(rows[s][k] for s in seeds)) for k in FIGURES[:3])
    per_seed = [rows[s]["waits_over_25_s"] for s in seeds]
    spread = f"{statistics.mean(per_seed):.2f} / {statistics.variance(per_seed):.2f}" if len(seeds) > 1 else "-"
    return (f"waits over 20 / 25 / 30 s {over}; within {bound:g} s on "
            f"{sum(rows[s]['longest_wait_s'] <= bound for s in seeds)} of {len(seeds)}; "
            f"{statistics.mean(rows[s]['done_per_min'] for s in seeds):.1f} tasks/min; cycle waits "
            f"{sum(rows[s]['cycle_waits'] for s in seeds)}; waits over 25 s per seed mean / variance {spread}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("new", type=Path, help="fleet_seeds.py --json output of the change")
    ap.add_argument("base", type=Path, help="the same of the baseline, on the same seeds")
    ap.add_argument("--bound", type=float, default=30.0, help="the wait bound, s (issue 17: 30)")
    a = ap.parse_args()
    try:
        new, base = load(a.new), load(a.base)
    except (OSError, ValueError) as e:  # a missing or malformed file: its name and line, no traceback
        raise SystemExit(str(e)) from None
    seeds = sorted(new.keys() & base.keys())
    if not seeds:
        raise SystemExit(f"no seed in both {a.new} and {a.base}")
    print(f"{len(seeds)} seeds in both ({len(new)} in {a.new.name}, {len(base)} in {a.base.name})")
    print(f"new:  {sums(new, seeds, a.bound)}")
    print(f"base: {sums(base, seeds, a.bound)}")
    for key in FIGURES:
        lower, higher, ties, p = paired(new, base, key)
        print(f"{key}: new lower on {lower} seeds, higher on {higher}, equal on {ties}; sign test p = {p:.2f}")


if __name__ == "__main__":
    main()
