"""The bridge over real Zenoh sessions on loopback, with SDK agents in this process (their own sessions)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
import zenoh

from fleet.agent import Agent
from fleet.zenoh_api import Keys
from fleet.zenoh_config import loopback
from sim.errors import ErrorCode, FleetError
from tests.fleet.zenoh_util import events_of, served, wait_until


def test_queries_answer_with_the_services_numbers():
    with served("robot_arena", robots={"r1": (-5.0, -5.0, 0.0), "r2": (-3.0, -5.0, 1.0)}) as (svc, _, ep), \
            Agent("reader", connect=ep) as agent:
        assert agent.keys.world == "robot_arena"
        state = agent.fleet_state()
        snap = svc.snapshot
        assert state["names"] == ["r1", "r2"] and state["x"][1] == -3.0 and state["yaw"][1] == 1.0
        assert state["stamp"] <= snap.time
        grid, res, origin = agent.occupancy_map()
        ref = svc.static_grid()
        assert res == ref.resolution and origin == ref.origin
        np.testing.assert_array_equal(grid, ref.data)  # the same map, cell for cell
        r1 = agent.robot("r1")
        pose = r1.wait("pose")
        assert (pose.x, pose.y) == pytest.approx((-5.0, -5.0), abs=1e-9)
        scan = r1.wait("scan")
        assert scan.ranges.size == 360 and scan.angles()[90] == pytest.approx(-np.pi / 2)
        # r1 faces east at y = -5; its right-hand beam meets the south wall's face at y = -6.0: 1 m (σ 1 cm)
        assert scan.ranges[90] == pytest.approx(1.0, abs=0.04)
        assert agent.sim_time >= scan.stamp > 0
        with pytest.raises(FleetError) as e:
            agent.request("lockstep", robots=["r1"])
        assert e.value.code is ErrorCode.UNSUPPORTED


def test_commands_go_through_the_safety_envelope_and_report_what_was_applied():
    with served(robots={"r1": (0.0, 0.0, 0.0)}) as (svc, bridge, ep), Agent("driver", connect=ep) as agent:
        r1 = agent.robot("r1")
        res = r1.drive_sync(5.0, -9.0)  # beyond the diffbot's 1 m/s and 2 rad/s
        assert (res["applied_v"], res["applied_w"], res["clamped"]) == (1.0, -2.0, True)
        assert "exceeds" in res["reason"] and res["stamp"] >= 0.0  # sim time of the command
        r1.drive(0.3, 0.0)
        wait_until(lambda: svc.snapshot.robot("r1").cmd_v == pytest.approx(0.3), what="the command applied")
        assert svc.safety.holder("r1") == "driver"  # the agent holds the lease now
        st = bridge.stats()["commands"]
        assert st["received"] == 1 and st["applied"] == 1 and st["lost"] == 0


def test_a_second_agent_cannot_control_a_leased_robot():
    with served(robots={"r1": (0.0, 0.0, 0.0)}) as (_, _, ep), Agent("first", connect=ep) as a, \
            Agent("second", connect=ep) as b:
        a.robot("r1").drive_sync(0.2, 0.0)
        with pytest.raises(FleetError) as e:
            b.robot("r1").drive_sync(0.2, 0.0)
        assert e.value.code is ErrorCode.LEASE_HELD and "first" in e.value.message
        with pytest.raises(FleetError) as e:
            b.navigate("r1", 2.0, 0.0)
        assert e.value.code is ErrorCode.LEASE_HELD
        b.robot("r1").drive(0.2, 0.0)  # fire-and-forget: the error comes back on b's error key
        assert b.wait_for(lambda: any(err["code"] == "LEASE_HELD" for err in b.errors), timeout=10)


def test_spawn_reset_and_liveliness_follow_the_world():
    with served(robots={"r1": (0.0, 0.0, 0.0)}) as (svc, _, ep), Agent("ops", connect=ep) as agent:
        k = agent.keys

        def alive_robots() -> set[str]:
            return {Keys.last(str(r.ok.key_expr)) for r in agent.session.liveliness().get(k.alive_robot("*"),
                                                                                         timeout=2) if r.ok}

        wait_until(lambda: alive_robots() == {"r1"}, what="r1's token")
        view = agent.spawn("r2", 2.0, 1.0, 0.5)
        assert (view["name"], view["x"], view["y"]) == ("r2", 2.0, 1.0)
        assert agent.wait_for(lambda: any(e["kind"] == "robot_spawned" and e["robots"] == ["r2"]
                                          for e in agent.events))
        wait_until(lambda: alive_robots() == {"r1", "r2"}, what="r2's token")
        with pytest.raises(FleetError) as e:
            agent.spawn("r2", 0.0, 0.0)
        assert e.value.code is ErrorCode.INVALID_ARGUMENT and "in use" in e.value.message
        assert agent.reset()["time"] == 0.0
        wait_until(lambda: alive_robots() == set(), what="tokens gone after reset")
        assert agent.wait_for(lambda: any(e["kind"] == "reset" for e in agent.events))
        agent.spawn("r3", 1.0, 1.0)  # streams come back on the rebuilt world
        assert agent.robot("r3").wait("scan").ranges.size == 360
        assert svc.world.robot_names() == ["r3"]


def test_an_agent_that_goes_away_releases_its_robot_at_once():
    with served(robots={"r1": (0.0, 0.0, 0.0)}) as (svc, bridge, ep):
        with Agent("leaver", connect=ep) as agent:
            agent.robot("r1").drive_sync(0.5, 0.0, duration=30.0)  # held for 30 s: only the bridge can stop it
            wait_until(lambda: svc.snapshot.robot("r1").v > 0.3, what="moving")
        wait_until(lambda: events_of(svc, "client_lost"), what="client_lost")
        ev = events_of(svc, "client_lost")[0]
        assert ev.robots == ("r1",) and ev.data["client"] == "leaver"
        wait_until(lambda: svc.snapshot.robot("r1").cmd_v == 0.0, what="the stop")
        assert svc.safety.holder("r1") is None and "leaver" not in bridge.agents
        assert events_of(svc, "agent_left")[0].data["agent"] == "leaver"


def test_camera_frames_come_on_request():
    with served(robots={"r1": (0.0, 0.0, 0.0)}) as (_, _, ep), Agent("eye", connect=ep) as agent:
        d = agent.query(agent.keys.robot("r1", "camera"), {"which": "rgb"}, timeout=30)
        assert (d["width"], d["height"], d["encoding"]) == (640, 480, "rgb8")
        assert len(np.frombuffer(__import__("base64").b64decode(d["data"]), np.uint8)) == 640 * 480 * 3


def test_ros2_keys_carry_cdr_that_ros_tools_understand():
    from fleet import cdr
    from fleet.zenoh_config import Ros2Config

    with served(robots={"r1": (1.0, 2.0, 0.0)}, ros2=Ros2Config(enabled=True)) as (svc, bridge, ep), \
            zenoh.open(loopback(int(ep.rsplit(":", 1)[1]), listen=False).to_zenoh()) as ros:
        got: dict[str, bytes] = {}

        def keep(topic: str) -> Callable[[zenoh.Sample], None]:
            def cb(s: zenoh.Sample) -> None:
                got.setdefault(topic, s.payload.to_bytes())
            return cb

        subs = [ros.declare_subscriber(f"r1/{t}", keep(t)) for t in ("scan", "odom")]
        wait_until(lambda: len(got) == 2, what="CDR scan and odometry")
        scan = cdr.decode_laser_scan(got["scan"])
        assert scan.header.frame_id == "r1/lidar" and scan.ranges.size == 360
        assert scan.angle_max == pytest.approx(scan.angle_min + 359 * scan.angle_increment, abs=1e-6)
        odom = cdr.decode_odometry(got["odom"])
        assert odom.child_frame_id == "r1/base_link" and odom.position[:2] == (1.0, 2.0)  # odom starts at spawn
        assert odom.orientation == (0.0, 0.0, 0.0, 1.0)
        ros.put("r1/cmd_vel", cdr.encode_twist(cdr.Twist((0.25, 0.0, 0.0), (0.0, 0.0, 0.1))))
        wait_until(lambda: svc.snapshot.robot("r1").cmd_v == pytest.approx(0.25), what="the ROS command applied")
        assert svc.snapshot.robot("r1").cmd_w == pytest.approx(0.1) and svc.safety.holder("r1") == "ros2"
        ros.put("r1/cmd_vel", b"\x00\x01\x00\x00\x01")  # truncated Twist: rejected, counted, logged
        wait_until(lambda: bridge.stats()["commands"]["malformed"] == 1, what="the malformed Twist rejected")
        assert svc.snapshot.robot("r1").cmd_v == pytest.approx(0.25)
        for s in subs:
            s.undeclare()
