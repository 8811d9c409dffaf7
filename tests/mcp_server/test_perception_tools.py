"""Perception tools in the arena against ground truth: detections on the crate's surface, the floor plane,
measured sensor rates and dropouts, calibration errors against the configured truth, EKF vs true pose."""

from __future__ import annotations

import pytest

from fleet import FleetService
from sim import Pose2D
from tests.mcp_server.helpers import err, image, ok

pytestmark = pytest.mark.anyio


@pytest.fixture(scope="module")
def world_name() -> str:
    return "robot_arena"


def crate_box(service: FleetService) -> tuple[float, float, float, float]:
    """The crate's footprint (xmin, ymin, xmax, ymax) from the world description."""
    desc = service.world.description
    crate = next(m for m in desc.models if m.name == "box_crate")
    return type(desc)(name="crate", models=(crate,)).bounds()


async def test_detection_lands_on_the_crate(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(-5.0, -5.0, 0.5))
    service.step(10)
    img, d = await image(client, "detect_objects", {"robot": "r1"})
    assert img.shape == (480, 640, 3)
    crate = next(x for x in d["detections"] if x["model"] == "box_crate")
    x0, y0, x1, y1 = crate_box(service)
    px, py, _ = crate["position"]
    assert x0 - 0.05 <= px <= x1 + 0.05 and y0 - 0.05 <= py <= y1 + 0.05  # a point on its visible surface
    assert all(x["model"] not in ("ground_plane", "r1") for x in d["detections"])
    await err(client, "detect_objects", {"robot": "r1", "min_pixels": 0}, "INVALID_ARGUMENT")
    await err(client, "detect_objects", {"robot": "ghost"}, "UNKNOWN_ROBOT")


async def test_segmentation_and_lidar_camera_overlay(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(-5.0, -5.0, 0.5))
    service.step(10)
    img, s = await image(client, "segment_camera_image", {"robot": "r1"})
    models = [c["model"] for c in s["classes"]]
    assert img.shape == (480, 640, 3) and models[0] == "box_crate" and "ground_plane" in models
    assert sum(c["fraction"] for c in s["classes"]) + s["background_fraction"] == pytest.approx(1.0, abs=1e-3)
    _, o = await image(client, "fuse_lidar_camera", {"robot": "r1"})
    assert 0 < o["projected"] <= o["returns"] and o["depth_range"][0] > 0
    await err(client, "segment_camera_image", {"robot": "ghost"}, "UNKNOWN_ROBOT")
    await err(client, "fuse_lidar_camera", {"robot": "ghost"}, "UNKNOWN_ROBOT")


async def test_scan_clusters_and_ground_plane(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(-5.0, -5.0, 0.5))
    await err(client, "process_sensor_data", {"robot": "r1"}, "NOT_FOUND")  # no scan yet
    service.step(10)
    c = (await ok(client, "process_sensor_data", {"robot": "r1", "operation": "clusters", "eps": 0.2}))["result"]
    x0, y0, x1, y1 = crate_box(service)
    assert any(x0 - 0.3 <= o["centre"][0] <= x1 + 0.3 and y0 - 0.3 <= o["centre"][1] <= y1 + 0.3
               for o in c["obstacles"]), "the crate's returns form a cluster at the crate"
    v = (await ok(client, "process_sensor_data", {"robot": "r1", "operation": "voxel_filter", "voxel": 0.5}))["result"]
    assert 0 < v["output_points"] < v["input_points"]
    g = (await ok(client, "process_sensor_data", {"robot": "r1", "operation": "ground_removal"}))["result"]
    assert g["plane"]["normal"][2] == pytest.approx(1.0, abs=0.01) and abs(g["plane"]["d"]) < 0.03  # the floor
    assert (await ok(client, "process_sensor_data", {"robot": "r1", "operation": "outlier_removal"}))["result"][
        "output_points"] > 0
    await err(client, "process_sensor_data", {"robot": "r1", "operation": "fft"}, "INVALID_ARGUMENT")


async def test_sensor_health_measures_rates_and_flags_a_dropout(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(-5.0, -5.0, 0.5))
    first = (await ok(client, "monitor_sensor_health", {"robot": "r1"}))["result"]
    assert first["monitoring_since"] == 0.0
    service.advance(3.0)
    h = {s["stream"]: s for s in (await ok(client, "monitor_sensor_health"))["result"]["streams"]}
    assert h["r1/scan"]["measured_hz"] == pytest.approx(10.0, rel=0.05)
    assert h["r1/imu"]["measured_hz"] == pytest.approx(100.0, rel=0.05) and h["r1/scan"]["alerts"] == []
    service.world.set_sensor_fault("r1", "lidar", dropout=True)
    service.advance(1.0)
    h = {s["stream"]: s for s in (await ok(client, "monitor_sensor_health", {"robot": "r1"}))["result"]["streams"]}
    assert "dropout" in [a["kind"] for a in h["r1/scan"]["alerts"]] and h["r1/scan"]["quality"] == 0.0
    await err(client, "monitor_sensor_health", {"robot": "ghost"}, "UNKNOWN_ROBOT")


async def test_calibration_recovers_the_truth(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(-5.0, -5.0, 0.5))
    imu = (await ok(client, "calibrate_sensor", {"robot": "r1", "kind": "imu_bias", "window_s": 1.0}))["result"]
    assert imu["samples"] == pytest.approx(100, abs=2) and imu["gyro_error"] < 0.002  # truth: zero bias
    lidar = (await ok(client, "calibrate_sensor", {"robot": "r1", "kind": "lidar_offset", "window_s": 1.0}))["result"]
    assert lidar["scans"] >= 9 and lidar["error_xy_m"] < 0.02
    cam = (await ok(client, "calibrate_sensor", {"robot": "r1", "kind": "camera_intrinsics"}))["result"]
    assert cam["camera"]["width"] == 640 and cam["camera"]["fx"] == pytest.approx(554.256, abs=0.01)
    await err(client, "calibrate_sensor", {"robot": "r1", "kind": "magnetometer"}, "INVALID_ARGUMENT")
    await err(client, "calibrate_sensor", {"robot": "ghost"}, "UNKNOWN_ROBOT")


async def test_odometry_imu_fusion_tracks_the_true_pose(client, service: FleetService) -> None:
    service.spawn_robot("r1", Pose2D(-5.0, -5.5, 0.0))
    f = await ok(client, "start_sensor_fusion", {"robot": "r1"})
    assert f["result"]["running"]
    await ok(client, "drive_robot", {"robot": "r1", "v": 0.4, "w": 0.2, "duration": 3.0})
    s = (await ok(client, "sensor_fusion_status", {"robot": "r1"}))["result"]
    assert s["updates"] > 300 and s["error_m"] < 0.05
    assert (await ok(client, "stop_sensor_fusion", {"robot": "r1"}))["result"]["running"] is False
    await err(client, "sensor_fusion_status", {"robot": "r1"}, "NOT_FOUND")
    await err(client, "stop_sensor_fusion", {"robot": "r1"}, "NOT_FOUND")
    await err(client, "start_sensor_fusion", {"robot": "r1", "config": {"gyro_std": -1.0}}, "INVALID_ARGUMENT")
