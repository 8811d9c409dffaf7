"""follow_waypoints: sequence with dwell, patrol rounds counted from the event bus, endless loops canceled."""

import pytest

from fleet import FleetConfig, FleetError, FleetService
from sim import Pose2D

SQUARE = [{"x": 2.0, "y": 0.0}, {"x": 2.0, "y": 2.0}, {"x": 0.0, "y": 2.0}]


@pytest.fixture()
def svc():
    s = FleetService(FleetConfig(world="empty"))
    s.spawn_robot("r1", Pose2D(0.0, 0.0, 0.0))
    yield s
    s.close()


def run_until_done(s, task_id, limit_s, chunk=1.0):
    t = 0.0
    while t < limit_s:
        s.advance(chunk)
        t += chunk
        st = s.task_status(task_id)
        if st["state"] not in ("queued", "active"):
            return st
    return s.task_status(task_id)


def test_patrol_rounds_are_counted_from_events_and_end_at_the_first_waypoint(svc):
    task = svc.follow_waypoints("r1", SQUARE, mode="patrol", rounds=2)
    st = run_until_done(svc, task["id"], 60)
    assert st["state"] == "succeeded"
    rounds = [e for e in svc.events.since(0, kinds=["round_completed"]) if e.data["task"] == task["id"]]
    assert [e.data["round"] for e in rounds] == [1, 2]
    visits = [e.data["index"] for e in svc.events.since(0, kinds=["waypoint_reached"])]
    assert visits == [0, 1, 2, 1, 0, 1, 2, 1, 0]  # there and back twice, turning points once per pass
    end = svc.robot("r1").pose
    assert end.distance_to(Pose2D(2.0, 0.0)) < 0.2  # back at waypoint 0
    assert st["progress"]["rounds_completed"] == 2


def test_sequence_dwells_at_each_waypoint(svc):
    wps = [{"x": 1.5, "y": 0.0, "dwell_s": 2.0}, {"x": 1.5, "y": 1.5}]
    task = svc.follow_waypoints("r1", wps, mode="sequence")
    st = run_until_done(svc, task["id"], 30, chunk=0.5)
    assert st["state"] == "succeeded"
    reached = svc.events.since(0, kinds=["waypoint_reached"])
    assert [e.data["index"] for e in reached] == [0, 1]
    # leaving waypoint 0 only after the dwell: the second leg (1.5 m) cannot take less than the dwell plus
    # the time a 1 m/s robot needs for it
    assert reached[1].stamp - reached[0].stamp >= 2.0 + 1.5 / 1.0
    assert svc.robot("r1").pose.distance_to(Pose2D(1.5, 1.5)) < 0.2


def test_endless_loop_runs_until_canceled(svc):
    task = svc.follow_waypoints("r1", SQUARE[:2], mode="loop", rounds=None)
    svc.advance(15)
    assert svc.task_status(task["id"])["state"] == "active"
    done = svc.task_status(task["id"])["progress"]["rounds_completed"]
    assert done >= 1
    assert svc.cancel_task(task["id"])["state"] == "canceled"
    svc.advance(2)
    assert svc.robot("r1").v == pytest.approx(0.0, abs=0.01)


@pytest.mark.parametrize("bad", [
    {"waypoints": []}, {"waypoints": SQUARE, "mode": "zigzag"}, {"waypoints": SQUARE, "rounds": 0},
    {"waypoints": [{"x": 1, "y": 1, "dwell_s": -1}]}, {"waypoints": [{"x": 1}]},
])
def test_bad_waypoint_params_fail_at_submit(svc, bad):
    with pytest.raises(FleetError) as err:
        svc.submit_task("follow_waypoints", "r1", bad)
    assert err.value.code.value == "INVALID_ARGUMENT"
