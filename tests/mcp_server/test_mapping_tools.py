"""SLAM and localisation tools on a robot driving in the arena, checked against ground truth."""

from __future__ import annotations

from pathlib import Path

import pytest

from fleet import FleetService
from sim import Pose2D
from tests.mcp_server.helpers import err, image, ok

pytestmark = pytest.mark.anyio


@pytest.fixture(scope="module")
def world_name() -> str:
    return "robot_arena"


async def test_slam_session_map_save_load_and_localise(client, service: FleetService, workspace: Path) -> None:
    service.spawn_robot("r1", Pose2D(-5.0, -5.5, 0.0))
    s = await ok(client, "start_slam", {"robot": "r1"})
    assert s["slam"]["running"] and s["slam"]["scans"] == 0
    await ok(client, "drive_robot", {"robot": "r1", "v": 0.5, "w": 0.0, "duration": 5.0})
    st = (await ok(client, "slam_status", {"robot": "r1"}))["slam"]
    assert st["scans"] >= 45 and st["keyframes"] >= 2
    assert st["ate"]["rmse_m"] < 0.1 and st["pose_error_m"] < 0.1  # against the recorded ground truth
    summary = (await ok(client, "slam_status", {"robot": "r1", "response_format": "summary"}))["slam"]
    assert "loop_closures" not in summary and summary["ate"] == st["ate"]
    img, meta = await image(client, "get_slam_map", {"robot": "r1"})
    assert max(img.shape[:2]) <= 800 and (img[..., :3] == 0).all(axis=-1).any()  # occupied cells are black
    assert meta["resolution"] == 0.05 and meta["source"] == "slam of r1"
    stopped = (await ok(client, "stop_slam", {"robot": "r1"}))["slam"]
    service.advance(1.0)
    assert not stopped["running"] and service.slam_status("r1")["scans"] == stopped["scans"]
    saved = (await ok(client, "save_slam_map", {"robot": "r1", "path": "maps/room.yaml"}))["map"]
    out = workspace / "outputs" / "maps"
    assert (out / "room.yaml").is_file() and (out / "room.pgm").is_file()
    loaded = (await ok(client, "load_slam_map", {"path": "maps/room.yaml", "name": "room2"}))["map"]
    assert (loaded["width"], loaded["height"]) == (saved["width"], saved["height"])
    assert {m["name"] for m in (await ok(client, "list_maps"))["maps"]} == {"room", "room2"}
    await image(client, "get_slam_map", {"map_name": "room2"})
    p = service.robot("r1").pose
    loc = await ok(client, "localize_robot", {"robot": "r1", "map_name": "room2", "x": p.x, "y": p.y, "yaw": p.yaw})
    assert loc["localization"]["running"]
    await ok(client, "drive_robot", {"robot": "r1", "v": -0.3, "w": 0.0, "duration": 2.0})
    q = (await ok(client, "localization_status", {"robot": "r1"}))["localization"]
    assert q["updates"] >= 15 and q["error_m"] < 0.1 and 0 <= q["quality"]["match_score"] <= 1
    assert (await ok(client, "stop_localization", {"robot": "r1"}))["localization"]["running"] is False


async def test_slam_bad_input(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(-5.0, -5.5, 0.0))
    await err(client, "slam_status", {"robot": "r1"}, "NOT_FOUND")
    await err(client, "start_slam", {"robot": "ghost"}, "UNKNOWN_ROBOT")
    await err(client, "start_slam", {"robot": "r1", "config": {"keyframes": {"distance": -1}}}, "INVALID_ARGUMENT")
    await err(client, "stop_slam", {"robot": "r1"}, "NOT_FOUND")
    await err(client, "save_slam_map", {"robot": "r1", "path": "maps/x.yaml"}, "NOT_FOUND")
    await err(client, "save_slam_map", {"robot": "r1", "path": "../x.yaml"}, "PATH_NOT_ALLOWED")
    await err(client, "load_slam_map", {"path": "maps/none.yaml"}, "NOT_FOUND")
    await err(client, "load_slam_map", {"path": "maps/none.png"}, "NOT_FOUND")
    await err(client, "localize_robot", {"robot": "r1", "map_name": "nope"}, "NOT_FOUND")
    await err(client, "localize_robot", {"robot": "r1", "map_name": "nope", "x": 1.0}, "INVALID_ARGUMENT")
    await err(client, "localization_status", {"robot": "r1"}, "NOT_FOUND")
    await err(client, "stop_localization", {"robot": "r1"}, "NOT_FOUND")
    await err(client, "get_slam_map", {}, "INVALID_ARGUMENT")
    await err(client, "get_slam_map", {"robot": "r1"}, "NOT_FOUND")
