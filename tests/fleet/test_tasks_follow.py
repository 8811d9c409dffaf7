"""follow_robot: keeps the distance behind a moving leader, ends on duration, cancel, or a vanished leader."""

import math

import pytest

from fleet import FleetConfig, FleetError, FleetService
from sim import Pose2D


@pytest.fixture()
def svc():
    s = FleetService(FleetConfig(world="empty"))
    s.spawn_robot("lead", Pose2D(0.0, 0.0, 0.0))
    s.spawn_robot("tail", Pose2D(-2.5, 0.0, 0.0))
    yield s
    s.close()


def test_follower_ends_the_distance_behind_the_leader(svc):
    follow = svc.follow_robot("tail", "lead", distance=1.0)
    go = svc.navigate("lead", Pose2D(3.0, 2.5, 0.0))
    svc.advance(20)
    assert svc.task_status(go["id"])["state"] == "succeeded"
    lead, tail = svc.robot("lead").pose, svc.robot("tail").pose
    behind = Pose2D(lead.x - math.cos(lead.yaw), lead.y - math.sin(lead.yaw))
    # holds within the navigator's goal tolerance plus the re-goal threshold (0.15 + 0.3 m)
    assert tail.distance_to(behind) < 0.45
    assert tail.distance_to(lead) == pytest.approx(1.0, abs=0.45)
    st = svc.task_status(follow["id"])
    assert st["state"] == "active" and st["progress"]["holding"]
    assert svc.cancel_task(follow["id"])["state"] == "canceled"


def test_follow_ends_succeeded_after_its_duration(svc):
    follow = svc.follow_robot("tail", "lead", duration=3.0)
    svc.advance(4.0)
    st = svc.task_status(follow["id"])
    assert st["state"] == "succeeded"
    assert st["finished"] - st["started"] == pytest.approx(3.0, abs=0.11)  # to a control period


def test_follow_fails_when_the_leader_is_removed(svc):
    follow = svc.follow_robot("tail", "lead")
    svc.advance(1.0)
    svc.remove_robot("lead")
    svc.advance(0.5)
    st = svc.task_status(follow["id"])
    assert st["state"] == "failed" and "gone" in st["reason"]


def test_follow_needs_a_known_other_robot(svc):
    with pytest.raises(FleetError) as err:
        svc.follow_robot("tail", "ghost")
    assert err.value.code.value == "UNKNOWN_ROBOT" and "lead" in err.value.hint
    with pytest.raises(FleetError, match="itself"):
        svc.follow_robot("tail", "tail")
