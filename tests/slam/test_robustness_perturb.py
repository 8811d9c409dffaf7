"""The perturbations of benchmarks/slam_robustness.py do what they say, on a small log built here: scans and
reference thinned together, beams halved at the right angles, odometry re-chained from noisier increments
(seeded, with the stated spread, steps without odometry left alone), range noise leaving no-returns alone, and
every copy keeping the log's reference kind and ODOM rates (thinned, biased or dropped with the odometry)."""

from __future__ import annotations

import math

import numpy as np

from benchmarks.slam_robustness import PERTURB
from sim.transforms import se2_between, se2_compose
from sim.types import LidarScan, Pose2D
from slam.log_run import LoadedLog
from slam.types import ScanRecord

N, BEAMS = 400, 181


def _log() -> LoadedLog:
    rng = np.random.default_rng(3)
    pose = (0.0, 0.0, 0.0)
    recs, ref = [], []
    for k in range(N):
        pose = se2_compose(pose, (0.2, 0.0, 0.05 * math.sin(k / 10)))
        ranges = rng.uniform(1.0, 10.0, BEAMS)
        ranges[::7] = np.inf  # no return
        scan = LidarScan("r", 0.1 * k, -math.pi / 2, math.pi / (BEAMS - 1), 0.1, 80.0, ranges)
        recs.append(ScanRecord(scan, Pose2D(*pose)))
        ref.append(pose)
    valid = np.ones(N, dtype=bool)
    valid[50:60] = False
    rates = np.column_stack([np.full(N, 2.0), np.zeros(N), 0.5 * np.sin(np.arange(N) / 10), np.full(N, 0.05)])
    return LoadedLog(recs, valid, np.array(ref), "carmen", "corrected", rates)


def test_drop2_thins_scans_and_reference_together() -> None:
    log = _log()
    out = PERTURB["drop2"](log, np.random.default_rng(1))
    assert len(out.records) == N // 2 and out.reference is not None and len(out.reference) == N // 2
    assert out.records[3] is log.records[6]
    assert log.reference is not None and np.array_equal(out.reference[3], log.reference[6])


def test_beams2_keeps_every_second_beam_at_its_angle() -> None:
    log = _log()
    out = PERTURB["beams2"](log, np.random.default_rng(1))
    a, b = log.records[5].scan, out.records[5].scan
    assert b.ranges.size == (BEAMS + 1) // 2
    np.testing.assert_allclose(b.angles(), a.angles()[::2])
    np.testing.assert_array_equal(b.ranges, a.ranges[::2])


def test_odom_noise_is_seeded_with_the_stated_spread() -> None:
    log = _log()
    out = PERTURB["odom"](log, np.random.default_rng(1))
    again = PERTURB["odom"](log, np.random.default_rng(1))
    assert all(r.odom == s.odom for r, s in zip(out.records, again.records, strict=True))
    dx, dyaw = [], []
    for k in range(1, N):
        if not (log.odom_valid[k] and log.odom_valid[k - 1]):
            continue
        o0, o1 = log.records[k - 1].odom, log.records[k].odom
        n0, n1 = out.records[k - 1].odom, out.records[k].odom
        assert o0 is not None and o1 is not None and n0 is not None and n1 is not None
        raw, new = se2_between(o0.as_tuple(), o1.as_tuple()), se2_between(n0.as_tuple(), n1.as_tuple())
        dx.append(new[0] - raw[0])
        dyaw.append(new[2] - raw[2])
    # σ_xy = 0.02 + 2 % of 0.2 m = 0.024 m; σ_yaw ≥ 0.5° (plus 3 % of turns ≤ 0.05 rad)
    assert 0.020 < float(np.std(dx)) < 0.028
    assert math.radians(0.45) < float(np.std(dyaw)) < math.radians(0.6)
    # the chain really drifts: the last pose differs from the raw odometry's
    last_raw, last_new = log.records[-1].odom, out.records[-1].odom
    assert last_raw is not None and last_new is not None and last_raw.distance_to(last_new) > 0.1
    assert np.array_equal(out.odom_valid, log.odom_valid)


def test_range_noise_and_no_odometry() -> None:
    log = _log()
    out = PERTURB["range"](log, np.random.default_rng(1))
    a, b = log.records[9].scan.ranges, out.records[9].scan.ranges
    assert np.array_equal(np.isinf(a), np.isinf(b))
    finite = np.isfinite(a)
    assert 0.02 < float(np.std(b[finite] - a[finite])) < 0.04
    assert not PERTURB["noodom"](log, np.random.default_rng(1)).odom_valid.any()


def test_copies_keep_reference_kind_and_odometry_rates() -> None:
    log = _log()
    assert log.odom_rates is not None
    for name in ("base", "odom", "range", "beams2", "blackout"):
        out = PERTURB[name](log, np.random.default_rng(1))
        assert out.reference_kind == "corrected" and out.odom_rates is log.odom_rates, name
    drop2 = PERTURB["drop2"](log, np.random.default_rng(1))
    assert drop2.reference_kind == "corrected" and drop2.odom_rates is not None
    np.testing.assert_array_equal(drop2.odom_rates, log.odom_rates[::2])
    noodom = PERTURB["noodom"](log, np.random.default_rng(1))
    assert noodom.reference_kind == "corrected" and noodom.odom_rates is None
    bias = PERTURB["yawbias"](log, np.random.default_rng(1))
    assert bias.odom_rates is not None
    # 2° per metre at 2 m/s: the turn rate gains 4°/s; speeds and intervals are untouched
    np.testing.assert_allclose(bias.odom_rates[:, 2] - log.odom_rates[:, 2], math.radians(4.0))
    np.testing.assert_array_equal(bias.odom_rates[:, [0, 1, 3]], log.odom_rates[:, [0, 1, 3]])
