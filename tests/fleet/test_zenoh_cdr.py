"""ROS 2 CDR codecs against bytes laid out by hand from the XCDR1 rules (little-endian, 4-byte encapsulation
header, alignment counted from the end of the header, strings length+bytes+NUL, sequences count+items)."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest

from fleet import cdr
from sim.errors import ErrorCode, FleetError

HDR = b"\x00\x01\x00\x00"


def test_twist_matches_hand_computed_bytes():
    data = cdr.encode_twist(cdr.Twist((1.0, 0.0, 0.0), (0.0, 0.0, 0.5)))
    expected = HDR + bytes.fromhex("000000000000f03f") + b"\x00" * 32 + bytes.fromhex("000000000000e03f")
    assert data == expected
    assert len(data) == 52
    back = cdr.decode_twist(data)
    assert back.linear == (1.0, 0.0, 0.0) and back.angular == (0.0, 0.0, 0.5)


def test_laser_scan_matches_hand_computed_bytes():
    scan = cdr.LaserScan(cdr.Header(1.5, "l"), -1.0, 1.0, 1.0, 0.0, 0.0, 0.5, 2.0,
                         np.array([1.0, 2.0, np.inf], dtype=np.float32))
    expected = (HDR
                + bytes.fromhex("01000000") + bytes.fromhex("0065cd1d")  # sec 1, nanosec 500000000
                + bytes.fromhex("02000000") + b"l\x00" + b"\x00\x00"  # "l" + NUL, padded to 4
                + bytes.fromhex("000080bf" "0000803f" "0000803f" "00000000" "00000000" "0000003f" "00000040")
                + bytes.fromhex("03000000") + bytes.fromhex("0000803f" "00000040" "0000807f")  # ranges, inf
                + bytes.fromhex("00000000"))  # no intensities
    data = cdr.encode_laser_scan(scan)
    assert data == expected
    back = cdr.decode_laser_scan(data)
    assert back.header == cdr.Header(1.5, "l")
    assert (back.angle_min, back.angle_max, back.range_min, back.range_max) == (-1.0, 1.0, 0.5, 2.0)
    np.testing.assert_array_equal(back.ranges, scan.ranges)
    assert back.intensities.size == 0


def test_odometry_matches_hand_computed_layout():
    cov = tuple(float(i) for i in range(36))
    odom = cdr.Odometry(cdr.Header(2.0, "odom"), "base_link", (1.0, 2.0, 0.0), cdr.yaw_quaternion(math.pi / 2), cov,
                        (0.5, 0.0, 0.0), (0.0, 0.0, 0.25), cov)
    q = (0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4))
    expected = (HDR + struct.pack("<iI", 2, 0) + struct.pack("<I", 5) + b"odom\x00" + b"\x00" * 3  # → offset 20
                + struct.pack("<I", 10) + b"base_link\x00" + b"\x00" * 6  # → offset 40, 8-aligned for doubles
                + struct.pack("<7d", 1.0, 2.0, 0.0, *q) + struct.pack("<36d", *cov)
                + struct.pack("<6d", 0.5, 0.0, 0.0, 0.0, 0.0, 0.25) + struct.pack("<36d", *cov))
    data = cdr.encode_odometry(odom)
    assert len(data) == 4 + 720
    assert data == expected
    back = cdr.decode_odometry(data)
    assert back.child_frame_id == "base_link" and back.header.frame_id == "odom"
    assert back.orientation == pytest.approx(q) and back.pose_covariance == cov
    assert back.linear == (0.5, 0.0, 0.0) and back.angular == (0.0, 0.0, 0.25)


@pytest.mark.parametrize("t, expected", [(0.0, (0, 0)), (1.25, (1, 250_000_000)), (3.9999999999, (4, 0)),
                                         (-0.5, (-1, 500_000_000))])
def test_stamp_split_keeps_nanoseconds_in_range(t, expected):
    assert cdr.split_stamp(t) == expected


def test_truncated_or_big_endian_payloads_are_rejected_with_a_reason():
    good = cdr.encode_twist(cdr.Twist((0.1, 0, 0), (0, 0, 0.2)))
    with pytest.raises(FleetError) as e:
        cdr.decode_twist(good[:30])
    assert e.value.code is ErrorCode.INVALID_ARGUMENT and "truncated" in e.value.message
    with pytest.raises(FleetError) as e:
        cdr.decode_twist(b"\x00\x00\x00\x00" + good[4:])  # CDR_BE
    assert "little-endian" in e.value.message
    scan = cdr.encode_laser_scan(cdr.LaserScan(cdr.Header(0, "x"), 0, 0, 0, 0, 0, 0, 1, np.ones(2, np.float32)))
    with pytest.raises(FleetError):
        cdr.decode_laser_scan(scan[:-6])  # the intensities count is cut
