"""Waypoint missions: order of visits for sequence / loop / patrol, dwell in sim time, failures, cancel."""

from __future__ import annotations

import pytest

from planning.nav_types import NavState, Waypoint
from planning.waypoints import WaypointFollower, visit_order
from sim.errors import FleetError
from sim.types import Pose2D
from tests.planning.test_navigator import TWO_ROOM_BOXES, TinyRobot, navigator
from tests.planning.worlds import two_rooms

CORNERS = [Pose2D(1.5, 1.5), Pose2D(3.5, 1.5), Pose2D(3.5, 4.5), Pose2D(1.5, 4.5)]  # the west room


def drive(follower: WaypointFollower, robot: TinyRobot, seconds: float, dt: float = 0.05) -> None:
    follower.start(robot.t)
    for _ in range(int(seconds / dt)):
        robot.step(follower.tick(robot.t, robot.pose, (robot.v, robot.w), robot.scan()), dt)
        if follower.state.done:
            return


def test_visit_orders():
    assert list(visit_order(3, "sequence", 5)) == [(0, 0), (1, 0), (2, 0)]
    assert list(visit_order(3, "loop", 2)) == [(0, 0), (1, 0), (2, 0), (0, 1), (1, 1), (2, 1)]
    assert [i for i, _ in visit_order(3, "patrol", 2)] == [0, 1, 2, 1, 0, 1, 2, 1, 0]
    endless = visit_order(2, "loop", None)
    assert [next(endless) for _ in range(5)] == [(0, 0), (1, 0), (0, 1), (1, 1), (0, 2)]


def test_patrol_visits_n_rounds_in_order():
    robot = TinyRobot(Pose2D(1.0, 1.0, 0.0), TWO_ROOM_BOXES)
    wps = [Waypoint(p) for p in CORNERS[:3]]
    follower = WaypointFollower(navigator=navigator(two_rooms()), waypoints=wps, mode="patrol", rounds=2)
    drive(follower, robot, 200.0)
    st = follower.status()
    assert st.state is NavState.SUCCEEDED, st.reason
    assert [v.index for v in st.visits] == [0, 1, 2, 1, 0, 1, 2, 1, 0]
    assert [v.round for v in st.visits] == [0, 0, 0, 0, 1, 1, 1, 1, 1]
    for v in st.visits:  # each visit really was at its waypoint
        assert v.pose.distance_to(wps[v.index].pose) <= 0.15
    assert all(b.arrived_at > a.arrived_at for a, b in zip(st.visits, st.visits[1:], strict=False))


def test_dwell_keeps_the_robot_stopped_for_that_sim_time():
    robot = TinyRobot(Pose2D(1.0, 1.0, 0.0), TWO_ROOM_BOXES)
    wps = [Waypoint(CORNERS[1], dwell_s=3.0), Waypoint(CORNERS[2])]
    follower = WaypointFollower(navigator=navigator(two_rooms()), waypoints=wps, mode="sequence")
    follower.start(0.0)
    leave = None
    arrived = None
    for _ in range(2000):
        cmd = follower.tick(robot.t, robot.pose, (robot.v, robot.w), robot.scan())
        if follower.status().visits and arrived is None:
            arrived = follower.status().visits[0].arrived_at
        if arrived is not None and leave is None and cmd != (0.0, 0.0):
            leave = robot.t
        robot.step(cmd, 0.05)
        if follower.state.done:
            break
    assert follower.state is NavState.SUCCEEDED
    assert arrived is not None and leave is not None
    assert leave - arrived == pytest.approx(3.0, abs=0.051)


def test_a_failed_leg_fails_the_mission_unless_skipping():
    wall = Waypoint(Pose2D(5.0, 1.0))  # inside the divider
    for skip, expected in ((False, NavState.FAILED), (True, NavState.SUCCEEDED)):
        robot = TinyRobot(Pose2D(1.0, 1.0, 0.0), TWO_ROOM_BOXES)
        follower = WaypointFollower(navigator=navigator(two_rooms()), waypoints=[wall, Waypoint(CORNERS[1])],
                                    skip_failed=skip)
        drive(follower, robot, 60.0)
        st = follower.status()
        assert st.state is expected and "waypoint 0" in st.reason
        assert [v.index for v in st.visits] == ([1] if skip else [])


def test_cancel_and_bad_input():
    robot = TinyRobot(Pose2D(1.0, 1.0, 0.0), TWO_ROOM_BOXES)
    follower = WaypointFollower(navigator=navigator(two_rooms()), waypoints=[Waypoint(CORNERS[2])], mode="loop",
                                rounds=None)
    drive(follower, robot, 1.0)
    follower.cancel()
    assert follower.state is NavState.CANCELED
    assert follower.tick(robot.t, robot.pose, (0.0, 0.0), None) == (0.0, 0.0)
    with pytest.raises(FleetError, match="no waypoints"):
        WaypointFollower(navigator=navigator(two_rooms()), waypoints=[])
    with pytest.raises(FleetError, match="rounds"):
        WaypointFollower(navigator=navigator(two_rooms()), waypoints=[Waypoint(CORNERS[0])], rounds=0)
