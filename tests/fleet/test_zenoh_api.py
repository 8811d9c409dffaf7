"""The key scheme, request validation, payload codecs (against the world's own readings) and the Zenoh config."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import zenoh

from fleet import FleetConfig, FleetService
from fleet.zenoh_api import (
    CmdVel,
    Keys,
    NavigateReq,
    RosKeys,
    check_name,
    decode,
    decode_odom,
    decode_scan,
    encode_fleet_state,
    encode_odom,
    encode_scan,
)
from fleet.zenoh_config import ZenohConfig, load_zenoh_config
from sim import Pose2D
from sim.errors import ErrorCode, FleetError

CONFIGS = Path(__file__).resolve().parents[2] / "configs" / "zenoh"


def test_keys_are_canonical_zenoh_key_expressions_and_parse_back():
    k = Keys("warehouse")
    for key in (k.robot("r1", "odom"), k.fleet("state"), k.command("navigate"), k.alive_agent("a-1"),
                k.agent_errors("a.b"), k.robot_any("cmd_vel")):
        assert str(zenoh.KeyExpr(key)) == key  # zenoh accepts it as is
        assert key.startswith("fleetnav/@v1/warehouse/")
    assert k.robot_of(k.robot("r7", "cmd_vel")) == "r7"
    assert Keys.world_of(k.alive_world()) == "warehouse"
    # `@v1` is a verbatim chunk: a plain wildcard never matches it, so versions never mix by accident
    assert not zenoh.KeyExpr("fleetnav/**").intersects(zenoh.KeyExpr(k.robot("r1", "odom")))
    assert zenoh.KeyExpr("fleetnav/@v1/**").intersects(zenoh.KeyExpr(k.robot("r1", "odom")))
    assert RosKeys("").topic("r1", "cmd_vel") == "r1/cmd_vel"
    assert RosKeys("/fleet/").topic("r1", "scan") == "fleet/r1/scan"
    assert RosKeys("fleet").robot_of("fleet/r3/cmd_vel") == "r3"


@pytest.mark.parametrize("bad", ["a/b", "*", "r$", "", "-x", "a" * 65])
def test_names_that_would_break_keys_are_rejected(bad):
    with pytest.raises(FleetError) as e:
        check_name("agent id", bad)
    assert e.value.code is ErrorCode.INVALID_ARGUMENT


def test_robot_keys_of_another_world_or_depth_are_rejected():
    k = Keys("empty")
    for key in ("fleetnav/@v1/other/robot/r1/cmd_vel", "fleetnav/@v1/empty/robot/r1/x/cmd_vel"):
        with pytest.raises(FleetError):
            k.robot_of(key)


def test_requests_are_validated_field_by_field():
    assert decode(CmdVel, b'{"v": 0.5, "w": -1, "agent": "a"}', "cmd").w == -1.0
    cases = {b"{not json": "not JSON", b'{"v": NaN, "w": 0}': "field 'v'", b'{"v": 1, "w": 0, "speed": 2}':
             "field 'speed'", b'{"w": 0}': "field 'v'", b"[1, 2]": "(payload)"}
    for payload, words in cases.items():
        with pytest.raises(FleetError) as e:
            decode(CmdVel, payload, "cmd")
        assert e.value.code is ErrorCode.INVALID_ARGUMENT and words in e.value.message, payload
        assert "v, w" in e.value.hint  # the hint lists the schema's fields
    with pytest.raises(FleetError) as e:
        decode(NavigateReq, b'{"robot": "r1", "goal": {"x": "far", "y": 1}}', "navigate")
    assert "goal.x" in e.value.message


def test_sensor_codecs_carry_the_worlds_readings_exactly():
    with FleetService(FleetConfig(world="robot_arena", seed=3)) as svc:
        svc.spawn_robot("r1", Pose2D(-5.0, -5.0, 0.3))
        svc.spawn_robot("r2", Pose2D(-4.0, -5.0, 0.0))
        svc.drive("r1", 0.4, 0.2)
        svc.advance(0.5)
        scan, odom = svc.world.latest_scan("r1"), svc.world.latest_odometry("r1")
        assert scan is not None and odom is not None
        s = decode_scan(encode_scan(scan))
        assert s.stamp == scan.stamp and s.angle_increment == scan.angle_increment
        np.testing.assert_array_equal(s.ranges, scan.ranges.astype(np.float32))  # +inf survives as no-return
        assert np.isinf(s.ranges).any() == np.isinf(scan.ranges).any()
        np.testing.assert_allclose(s.angles(), scan.angles())
        o = decode_odom(encode_odom(odom))
        assert (o.stamp, o.x, o.y, o.yaw, o.v, o.w) == (odom.stamp, odom.pose.x, odom.pose.y, odom.pose.yaw,
                                                        odom.linear, odom.angular)
        snap = svc.snapshot
        d = json.loads(encode_fleet_state(snap, 5))
        assert d["names"] == ["r1", "r2"] and d["tick"] == 5 and d["stamp"] == snap.time
        np.testing.assert_array_equal(np.array([d["x"], d["y"], d["yaw"]]).T, snap.pose)
        np.testing.assert_array_equal(d["cmd_v"], snap.cmd[:, 0])


def test_sample_configs_load_and_zenoh_accepts_them():
    names = sorted(p.name for p in CONFIGS.glob("*.yaml"))
    assert {"local.yaml", "secure.yaml", "lockstep.yaml", "ros2.yaml"} <= set(names)
    for p in CONFIGS.glob("*.yaml"):
        load_zenoh_config(p).to_zenoh()  # Zenoh validates every key it is given
    secure = load_zenoh_config(CONFIGS / "secure.yaml")
    settings = secure.json5_settings()
    assert settings["transport/link/tls"]["enable_mtls"] is True
    assert settings["access_control"]["default_permission"] == "deny"  # passed through verbatim
    assert settings["scouting/multicast/enabled"] is False and secure.listen[0].startswith("tls/")


def test_config_errors_name_the_file_line_and_field(tmp_path):
    bad = tmp_path / "z.yaml"
    bad.write_text("mode: peer\nlisten: [127.0.0.1:7447]\n")
    with pytest.raises(FleetError) as e:
        load_zenoh_config(bad)
    assert f"{bad}:2" in e.value.message and "listen" in e.value.message
    with pytest.raises(FleetError) as e:
        ZenohConfig(access_control={"enabled": True, "rules": [{"messages": ["shout"]}]}).to_zenoh()
    assert e.value.code is ErrorCode.INVALID_CONFIG and "shout" in e.value.message
