"""Debug and record tools: markers in the map image and the event log, highlights, events, MCAP recordings."""

from __future__ import annotations

from pathlib import Path

import pytest

from fleet import FleetService
from sim import Pose2D
from tests.mcp_server.helpers import err, image, ok

pytestmark = pytest.mark.anyio


async def test_markers_are_drawn_into_the_map_and_logged(client, service: FleetService) -> None:
    m = await ok(client, "add_debug_marker", {"kind": "circle", "points": [[2.0, 2.0]], "size": 0.5,
                                              "colour": "magenta", "text": "here", "lifetime_s": 5.0})
    assert m["marker"]["kind"] == "circle" and m["marker"]["expires"] == pytest.approx(5.0)
    img, meta = await image(client, "get_occupancy_map", {})
    mpp, (xmin, _), ymax = meta["metres_per_pixel"], meta["origin"], meta["bounds"][3]
    ring = img[int((ymax - 2.0) / mpp), int((2.5 - xmin) / mpp) - 1]  # the circle's right edge
    assert tuple(ring[:3]) == (210, 0, 160)
    ev = await ok(client, "recent_events", {"kinds": ["debug_marker"]})
    assert ev["events"][-1]["data"]["marker"]["id"] == m["marker"]["id"]
    await ok(client, "add_debug_marker", {"kind": "arrow", "points": [[0, 0], [1, 1]], "ns": "plans"})
    assert (await ok(client, "list_debug_markers"))["count"] == 2
    assert (await ok(client, "list_debug_markers", {"ns": "plans"}))["count"] == 1
    service.advance(5.0)  # the circle expires in sim time
    assert [x["kind"] for x in (await ok(client, "list_debug_markers"))["markers"]] == ["arrow"]
    c = await ok(client, "clear_debug_markers", {})
    assert len(c["cleared"]) == 1 and service.list_markers() == []
    await err(client, "add_debug_marker", {"kind": "line", "points": [[0, 0]]}, "INVALID_ARGUMENT")
    await err(client, "add_debug_marker", {"kind": "hologram", "points": [[0, 0]]}, "INVALID_ARGUMENT")
    await err(client, "add_debug_marker", {"kind": "point", "points": [[0, 0]], "colour": [300, 0, 0]},
              "INVALID_ARGUMENT")
    await err(client, "clear_debug_markers", {"marker_id": "m999"}, "NOT_FOUND")


async def test_highlight_outlines_a_robot(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(1.0, 1.0, 0.0))
    h = await ok(client, "highlight_model", {"name": "r1", "colour": "cyan"})
    r = service.world.robot_spec("r1").footprint_radius + 0.1
    flat = [v for p in h["marker"]["points"] for v in p]
    assert flat == pytest.approx([1 - r, 1 - r, 1 + r, 1 + r], abs=1e-3)
    await err(client, "highlight_model", {"name": "ghost"}, "UNKNOWN_MODEL")


async def test_recent_events_poll_by_sequence_and_robot(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    service.spawn_robot("r2", Pose2D(2, 0, 0))
    first = await ok(client, "recent_events", {})
    assert [e["kind"] for e in first["events"]][-2:] == ["robot_spawned", "robot_spawned"]
    service.estop("r2")
    new = await ok(client, "recent_events", {"since_seq": first["last_seq"]})
    assert [e["kind"] for e in new["events"]] == ["estop"] and new["events"][0]["robots"] == ["r2"]
    mine = await ok(client, "recent_events", {"robot": "r1"})
    assert all("r1" in e["robots"] for e in mine["events"])
    await err(client, "recent_events", {"since_seq": -1}, "INVALID_ARGUMENT")


async def test_record_list_and_replay(client, service: FleetService, workspace: Path) -> None:
    service.spawn_robot("r1", Pose2D(0, 0, 0))
    await ok(client, "start_recording", {"path": "rec/run.mcap"})
    await err(client, "start_recording", {"path": "rec/other.mcap"}, "BUSY")
    service.drive("r1", 0.5, 0.3, duration=2.0)
    service.advance(2.0)
    done = (await ok(client, "stop_recording"))["recording"]
    assert done["messages"]["/fleetnav/state"] == 20 and done["messages"]["/r1/scan"] == 20
    assert (workspace / "outputs" / "rec" / "run.mcap").stat().st_size == done["bytes"]
    listed = (await ok(client, "list_recordings", {"directory": "rec"}))["recordings"]
    assert listed[0]["path"] == "outputs/rec/run.mcap" and listed[0]["topics"]["/tf"] == 20
    rep = (await ok(client, "replay_recording", {"path": "rec/run.mcap"}))["recording"]
    assert rep["robots"] == ["r1"] and rep["ticks"] >= 19 and rep["max_divergence_m"]["r1"] < 0.01
    await err(client, "stop_recording", {}, "NOT_FOUND")
    await err(client, "start_recording", {"path": "/tmp/x.mcap"}, "PATH_NOT_ALLOWED")
    await err(client, "start_recording", {"path": "rec/x.txt"}, "INVALID_ARGUMENT")
    await err(client, "list_recordings", {"directory": "nope"}, "NOT_FOUND")
    await err(client, "replay_recording", {"path": "rec/none.mcap"}, "NOT_FOUND")
