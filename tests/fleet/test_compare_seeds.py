"""benchmarks/compare_seeds.py: the paired sign test in closed form, the pairing on common seeds, bad files named,
and fleet_seeds.py's JSON rows readable by it."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from benchmarks.compare_seeds import load, paired, sign_test
from benchmarks.fleet_seeds import json_row

ROW = {"done_per_min": 90.0, "waits_over_20_s": 3, "waits_over_25_s": 1, "waits_over_30_s": 0,
       "longest_deadlock_s": 26.0, "longest_open_s": 0.0, "cycle_waits": 0}


def write(path: Path, rows: list[dict[str, object]]) -> Path:
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    return path


def test_sign_test_is_the_exact_two_sided_binomial() -> None:
    assert sign_test(8, 0) == pytest.approx(2 / 2**8)  # all 8 one way: 2 · (1/2)^8
    assert sign_test(0, 8) == pytest.approx(2 / 2**8)
    assert sign_test(1, 3) == pytest.approx(2 * (1 + 4) / 16)  # P(X ≤ 1) for n = 4, doubled
    assert sign_test(5, 5) == 1.0 and sign_test(0, 0) == 1.0  # capped at 1; no seed differs


def test_pairs_on_the_common_seeds_only(tmp_path: Path) -> None:
    new = write(tmp_path / "new.jsonl", [{**ROW, "seed": s, "waits_over_25_s": w} for s, w in [(0, 0), (1, 2), (2, 1),
                                                                                                (9, 0)]])
    base = write(tmp_path / "base.jsonl", [{**ROW, "seed": s, "waits_over_25_s": w} for s, w in [(0, 1), (1, 1),
                                                                                                 (2, 1), (5, 4)]])
    a, b = load(new), load(base)
    assert paired(a, b, "waits_over_25_s") == (1, 1, 1, 1.0)  # seed 0 lower, 1 higher, 2 equal; 5 and 9 unpaired
    # the longest wait is the longer of the closed and the still-open one, as fleet_seeds.within reads it
    still_open = load(write(tmp_path / "open.jsonl", [{**ROW, "seed": 0, "longest_open_s": 31.0}]))
    assert still_open[0]["longest_wait_s"] == 31.0 and a[0]["longest_wait_s"] == 26.0
    assert paired(still_open, b, "longest_wait_s") == (0, 1, 0, 1.0)


def test_a_bad_line_is_named_with_its_file_and_line(tmp_path: Path) -> None:
    path = tmp_path / "run.jsonl"
    path.write_text(json.dumps({**ROW, "seed": 0}) + "\n{not json\n")
    with pytest.raises(ValueError, match=r"run\.jsonl:2: not JSON"):
        load(path)
    path.write_text(json.dumps({"seed": 0, "waits_over_20_s": 1}) + "\n")
    with pytest.raises(ValueError, match=r"run\.jsonl:1: missing done_per_min"):
        load(path)


def test_fleet_seeds_rows_are_plain_json_that_compare_reads(tmp_path: Path) -> None:
    r = {**ROW, "seed": np.int64(3), "waits_over_25_s": np.int64(2), "longest_deadlock_s": np.float64(28.5),
         "avoidance": "traffic", "per_robot": np.zeros(3)}
    row = json_row(r)
    assert row["seed"] == 3 and type(row["seed"]) is int and type(row["longest_deadlock_s"]) is float
    assert "per_robot" not in row and row["avoidance"] == "traffic"
    got = load(write(tmp_path / "r.jsonl", [row]))
    assert got[3]["waits_over_25_s"] == 2 and got[3]["longest_wait_s"] == 28.5
