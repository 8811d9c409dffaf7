"""LaserScan messages from MCAP: ROS 2 CDR and JSON (our writer), Foxglove protobuf (foxglove's encoder)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from mcap.writer import Writer

from sim.errors import FleetError
from slam.io_mcap import read_mcap_scans, write_mcap_scans
from tests.slam import synth


def _scans(n: int) -> list:
    rng = np.random.default_rng(1)
    return [synth.raycast(synth.room(), p, noise=0.01, rng=rng, stamp=12.0 + 0.1 * k)
            for k, p in enumerate(synth.loop_path(n, 0.1))]


@pytest.mark.parametrize("encoding", ["cdr", "json"])
def test_laserscans_round_trip_through_mcap(tmp_path: Path, encoding: str) -> None:
    scans = _scans(5)
    assert write_mcap_scans(tmp_path / "s.mcap", scans, encoding=encoding) == 5  # type: ignore[arg-type]
    back = [r.scan for r in read_mcap_scans(tmp_path / "s.mcap", topic="/scan")]
    assert len(back) == 5
    for a, b in zip(scans, back, strict=True):
        assert b.stamp == pytest.approx(a.stamp, abs=1e-9)
        assert b.angle_min == pytest.approx(a.angle_min, abs=1e-6)
        assert b.angle_increment == pytest.approx(a.angle_increment, abs=1e-7)
        fa, fb = np.isfinite(a.ranges), np.isfinite(b.ranges)
        assert np.array_equal(fa, fb)
        tol = 1e-5 if encoding == "cdr" else 1e-12  # CDR carries float32
        np.testing.assert_allclose(b.ranges[fb], a.ranges[fa], atol=tol)


def test_foxglove_protobuf_laserscan_decodes(tmp_path: Path) -> None:
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        from foxglove.messages import LaserScan, Timestamp

    ranges = [1.0, 2.5, math.inf, 4.25]
    msg = LaserScan(timestamp=Timestamp(sec=3, nsec=500_000_000), frame_id="lidar", start_angle=-1.5,
                    end_angle=1.5, ranges=ranges, intensities=[])
    schema = LaserScan.get_schema()
    with (tmp_path / "fox.mcap").open("wb") as f:
        w = Writer(f)
        w.start()
        sid = w.register_schema(schema.name, schema.encoding, schema.data)
        cid = w.register_channel("/lidar", "protobuf", sid)
        w.add_message(cid, log_time=3_500_000_000, publish_time=3_500_000_000, data=msg.encode())
        w.finish()
    (rec,) = list(read_mcap_scans(tmp_path / "fox.mcap"))
    assert rec.scan.stamp == pytest.approx(3.5)
    assert rec.scan.angle_min == pytest.approx(-1.5) and rec.scan.angle_increment == pytest.approx(1.0)
    assert rec.scan.ranges[[0, 1, 3]].tolist() == [1.0, 2.5, 4.25] and math.isinf(rec.scan.ranges[2])


def test_mcap_without_laserscans_is_an_error(tmp_path: Path) -> None:
    with (tmp_path / "other.mcap").open("wb") as f:
        w = Writer(f)
        w.start()
        sid = w.register_schema("foo/Bar", "jsonschema", b"{}")
        w.add_message(w.register_channel("/foo", "json", sid), log_time=0, publish_time=0, data=b"{}")
        w.finish()
    with pytest.raises(FleetError, match="no LaserScan"):
        list(read_mcap_scans(tmp_path / "other.mcap"))
