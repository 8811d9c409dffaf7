"""dock_and_charge end to end (low_battery → dock → charged), docks from `dock_*` models, return_home."""

from contextlib import closing

import pytest

from fleet import BatteryConfig, FleetConfig, FleetError, FleetService
from sim import Pose2D

from .test_tasks_waypoints import run_until_done

PAD = ('<model name="{name}"><static>true</static><pose>{x} {y} 0 0 0 0</pose><link name="link">'
       '<visual name="pad"><pose>0 0 0.01 0 0 0</pose><geometry><box><size>1 0.8 0.02</size></box></geometry>'
       '</visual></link></model>')
DOCKS = {"dock_east": (3.0, -2.0), "dock_west": (-3.0, 3.0)}
BATTERY = BatteryConfig(capacity_wh=1.0, low_threshold=0.3)  # a small battery: minutes become seconds


def dock_world(tmp_path):
    """empty.world plus two visual-only dock pads, like warehouse.world's dock_* models."""
    from fleet.paths import world_file

    text = world_file("empty").read_text()
    pads = "".join(PAD.format(name=n, x=x, y=y) for n, (x, y) in DOCKS.items())
    path = tmp_path / "docks.world"
    path.write_text(text.replace("</world>", pads + "</world>"))
    return str(path)


@pytest.fixture()
def svc(tmp_path):
    s = FleetService(FleetConfig(world=dock_world(tmp_path), battery=BATTERY))
    s.spawn_robot("r1", Pose2D(0.0, 0.0, 0.0))
    yield s
    s.close()


def test_docks_come_from_dock_models_and_the_battery_charges_there(svc):
    assert {d["name"]: (d["x"], d["y"]) for d in svc.list_docks()} == DOCKS
    assert sorted(map(tuple, svc.battery.docks.tolist())) == sorted(DOCKS.values())


def test_low_robot_goes_to_the_nearest_dock_and_charges_to_target(svc):
    svc.set_battery("r1", 0.31)
    task = svc.dock_and_charge("r1", target_soc=0.8)
    st = run_until_done(svc, task["id"], 60)
    assert st["state"] == "succeeded"
    assert st["progress"]["dock"] == "dock_east"  # 3.6 m away, dock_west 4.2 m
    r = svc.robot("r1")
    assert r.pose.distance_to(Pose2D(*DOCKS["dock_east"])) < BATTERY.dock_radius
    assert r.battery >= 0.8
    kinds = [e.kind for e in svc.events.since(0) if e.kind in ("low_battery", "docked", "charged", "task_finished")]
    assert kinds == ["low_battery", "docked", "charged", "task_finished"]


def test_charging_on_the_dock_follows_the_constant_power_model(svc):
    svc.set_battery("r1", 0.2)
    task = svc.dock_and_charge("r1", target_soc=1.0)
    for _ in range(100):  # until it stands still on the dock
        svc.advance(0.5)
        if svc.task_status(task["id"])["progress"].get("phase") == "charging" and abs(svc.robot("r1").v) < 1e-3:
            break
    t0, soc0 = svc.snapshot.time, svc.robot("r1").battery
    svc.advance(3.0)
    assert svc.task_status(task["id"])["state"] == "active"
    rate = (BATTERY.charge_w - BATTERY.idle_w) / (BATTERY.capacity_wh * 3600.0)  # state of charge per second
    assert (svc.robot("r1").battery - soc0) / (svc.snapshot.time - t0) == pytest.approx(rate, rel=0.01)


def test_named_dock_is_used(svc):
    task = svc.dock_and_charge("r1", "dock_west", target_soc=0.5)
    st = run_until_done(svc, task["id"], 60)
    assert st["state"] == "succeeded"
    assert svc.robot("r1").pose.distance_to(Pose2D(*DOCKS["dock_west"])) < BATTERY.dock_radius


def test_unknown_dock_lists_the_docks(svc):
    with pytest.raises(FleetError) as err:
        svc.dock_and_charge("r1", "dock_nowhere")
    assert "dock_east" in err.value.hint and "dock_west" in err.value.hint


def test_world_without_docks_says_so():
    with closing(FleetService(FleetConfig(world="empty"))) as s:
        s.spawn_robot("r1", Pose2D())
        with pytest.raises(FleetError, match="no docks"):
            s.dock_and_charge("r1")


def test_return_home_goes_back_to_the_spawn_pose(svc):
    go = svc.navigate("r1", Pose2D(2.0, 2.0, 0.0))
    assert run_until_done(svc, go["id"], 20)["state"] == "succeeded"
    home = svc.return_home("r1")
    assert run_until_done(svc, home["id"], 20)["state"] == "succeeded"
    p = svc.robot("r1").pose
    assert p.distance_to(Pose2D(0.0, 0.0)) < 0.2
    assert abs(p.yaw) < 0.15  # turned to the home heading
