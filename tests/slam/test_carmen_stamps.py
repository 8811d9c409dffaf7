"""CARMEN logs whose stamps carry no time (Radish orebro: every laser stamp 0, ODOM stamps uninitialised):
the raw ODOM increments are read in file order, and only the steps with a raw ODOM line have odometry."""

from __future__ import annotations

from pathlib import Path

import pytest

from slam.io_carmen import read_carmen


def _flaser(pose: tuple[float, float, float]) -> str:
    r = " ".join("2.000" for _ in range(181))
    x, y, th = pose
    return f"FLASER 181 {r} {x} {y} {th} {x} {y} {th} 0 pippo 0"


def test_zero_stamps_read_in_file_order(tmp_path: Path) -> None:
    # corrected poses 0 → 2.1 → 2.1 (turn) → 4.0; raw ODOM increments only before the 2nd and 4th scans
    # (+2.0 in x; then, from the restart at (2.1, 0, 0.5), a −0.5 rad turn); each laser line is followed by
    # a restart at its pose with a garbage stamp.
    lines = ["ODOM 0 0 0 0 0 0 0 pippo 0", _flaser((0, 0, 0)), "ODOM 0 0 0 0 0 0 6.979 pippo 6.979",
             "ODOM 2.0 0 0 0 0 0 0 pippo 0", _flaser((2.1, 0, 0)), "ODOM 2.1 0 0 0 0 0 3.4e-86 pippo 3.4e-86",
             _flaser((2.1, 0, 0.5)), "ODOM 2.1 0 0.5 0 0 0 -1891.7 pippo -1891.7",
             "ODOM 2.1 0 0 0 0 0 0 pippo 0", _flaser((4.0, 0, 0)), "ODOM 4.0 0 0 0 0 0 1.9 pippo 1.9"]
    (tmp_path / "o.log").write_text("\n".join(lines) + "\n")
    log = read_carmen(tmp_path / "o.log")
    odo = [r.odom.as_tuple() for r in log.records if r.odom is not None]
    assert len(odo) == 4
    assert odo[0] == pytest.approx((0.0, 0.0, 0.0), abs=1e-12)
    assert odo[1] == pytest.approx((2.0, 0.0, 0.0), abs=1e-12)
    assert odo[2] == pytest.approx((2.0, 0.0, 0.0), abs=1e-12)  # no raw ODOM before it: no motion observed
    assert odo[3] == pytest.approx((2.0, 0.0, -0.5), abs=1e-12)
    assert log.odom_valid is not None and log.odom_valid.tolist() == [False, True, False, True]
