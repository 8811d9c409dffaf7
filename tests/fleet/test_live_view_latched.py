"""A Foxglove viewer that connects after the world started still receives the static data: /map and the robot
descriptions (sent once at start, re-sent on subscribe)."""

from __future__ import annotations

import json
import time

from fleet import FleetConfig, FleetService
from fleet.live_view import ROBOTS_TOPIC, LiveView
from sim import Pose2D
from tests.fleet.ws_viewer import Viewer
from tests.fleet.zenoh_util import free_port, wait_until


def test_a_late_viewer_receives_the_map_and_the_robot_descriptions():
    svc = FleetService(FleetConfig(world="robot_arena", seed=1))
    view = None
    try:
        svc.spawn_robot("r1", Pose2D(-5.0, -5.0, 0.0))
        view = LiveView(port=free_port()).attach(svc)
        svc.start("realtime", 2.0)
        wait_until(lambda: svc.snapshot.time > 0.5, what="the world running")  # /map went out long ago
        viewer = Viewer("127.0.0.1", int(view.url.rsplit(":", 1)[1]))
        try:
            deadline = time.monotonic() + 5.0
            while not {"/map", ROBOTS_TOPIC} <= set(viewer.channels) and time.monotonic() < deadline:
                viewer.pump(time.monotonic() + 0.2)
            viewer.subscribe("/map", ROBOTS_TOPIC)
            robots = viewer.wait_for(ROBOTS_TOPIC)
            assert robots, "no robot descriptions for the late viewer"
            desc = json.loads(robots[-1])
            assert [r["name"] for r in desc["robots"]] == ["r1"] and desc["robots"][0]["model"] == "diffbot"
            assert desc["robots"][0]["description"]["limits"]["max_linear"] > 0
            assert viewer.wait_for("/map"), "no /map for the late viewer"
            assert view.resent["/map"] >= 1
            svc.spawn_robot("r2", Pose2D(-5.0, -3.0, 0.0))  # a change goes out to subscribers at once

            def names() -> list[str]:
                viewer.pump(time.monotonic() + 0.1)
                return [r["name"] for r in json.loads(viewer.messages[ROBOTS_TOPIC][-1])["robots"]]

            wait_until(lambda: names() == ["r1", "r2"], what="r2's description")
        finally:
            viewer.close()
    finally:
        if view is not None:
            view.close()
        svc.close()


def test_a_late_viewer_of_a_recorded_run_receives_the_map(tmp_path):
    from fleet.recording.mcap_recorder import McapRecorder

    svc = FleetService(FleetConfig(world="robot_arena", seed=1))
    view = LiveView(port=free_port())
    rec = McapRecorder(tmp_path / "run.mcap", live=view)
    try:
        rec.attach(svc, "", 1)
        svc.start("realtime", 2.0)
        wait_until(lambda: svc.snapshot.time > 0.5, what="the world running")
        viewer = Viewer("127.0.0.1", int(view.url.rsplit(":", 1)[1]))
        try:
            deadline = time.monotonic() + 5.0
            while "/map" not in viewer.channels and time.monotonic() < deadline:
                viewer.pump(time.monotonic() + 0.2)
            viewer.subscribe("/map")
            assert viewer.wait_for("/map"), "no /map for the late viewer"
        finally:
            viewer.close()
    finally:
        svc.close()
        rec.close()
