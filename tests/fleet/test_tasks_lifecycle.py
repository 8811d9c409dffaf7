"""Task lifecycle through the façade: bad input fails at once with the valid names, cancel ends as canceled,
an impossible goal ends as failed(reason), a time window holds a task back."""

import pytest

from fleet import FleetConfig, FleetError, FleetService
from fleet.tasks import allocatable_types, task_types
from sim import Pose2D


@pytest.fixture(scope="module")
def arena():
    s = FleetService(FleetConfig(world="robot_arena"))
    s.spawn_robot("r1", Pose2D(-5.0, -5.0, 0.0))
    s.spawn_robot("r2", Pose2D(5.0, -5.0, 0.0))
    yield s
    s.close()


def test_all_task_types_are_registered():
    assert set(task_types()) >= {"go_to", "follow_waypoints", "cover_area", "follow_robot", "dock_and_charge",
                                 "return_home", "wait", "stop"}
    assert allocatable_types() == ["cover_area", "follow_waypoints", "go_to", "traffic_go"]


def test_task_for_an_unknown_robot_fails_with_the_list_of_robots(arena):
    with pytest.raises(FleetError) as err:
        arena.navigate("r9", Pose2D(0.0, 0.0, 0.0))
    assert err.value.code.value == "UNKNOWN_ROBOT"
    assert "r1" in err.value.hint and "r2" in err.value.hint


def test_unknown_task_type_lists_the_types(arena):
    with pytest.raises(FleetError) as err:
        arena.submit_task("teleport", "r1", {})
    assert "follow_waypoints" in err.value.hint and "dock_and_charge" in err.value.hint


def test_goal_inside_a_wall_ends_failed_with_the_reason(arena):
    task = arena.navigate("r1", Pose2D(-1.7, -2.5, 0.0))  # the middle of barrier_south
    arena.advance(1.0)
    st = arena.task_status(task["id"])
    assert st["state"] == "failed"
    assert "planning failed" in st["reason"]
    assert arena.robot("r1").pose.distance_to(Pose2D(-5.0, -5.0)) < 0.05  # it did not move


def test_cancel_ends_canceled_and_the_robot_stops(arena):
    task = arena.navigate("r2", Pose2D(5.0, 5.0, 0.0))
    arena.advance(4.0)
    assert arena.robot("r2").pose.distance_to(Pose2D(5.0, -5.0)) > 0.3
    assert arena.robot("r2").v > 0.1  # under way when canceled
    assert arena.cancel_task(task["id"])["state"] == "canceled"
    arena.advance(2.0)
    assert arena.task_status(task["id"])["state"] == "canceled"
    assert arena.robot("r2").v == pytest.approx(0.0, abs=0.01)
    assert any(e.kind == "task_canceled" and e.data["task"] == task["id"] for e in arena.events.since(0))


def test_wait_task_and_a_time_window_hold_the_robot(arena):
    now = arena.snapshot.time
    held = arena.call(lambda: arena.tasks.submit("wait", "r1", {"seconds": 1.0}, not_before=now + 2.0).to_dict())
    assert held["not_before"] == pytest.approx(now + 2.0)
    arena.advance(1.5)
    assert arena.task_status(held["id"])["state"] == "queued"
    arena.advance(2.0)
    st = arena.task_status(held["id"])
    assert st["state"] == "succeeded"
    assert st["started"] == pytest.approx(now + 2.0, abs=0.11)
    assert st["finished"] - st["started"] == pytest.approx(1.0, abs=0.11)
