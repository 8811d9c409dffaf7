"""FleetService operations over sim.perception on live robots: object detection and segmentation of a freshly
rendered camera image, lidar–camera overlay, lidar / depth-cloud processing, and sensor health.

Everything renders or reads on the sim thread (the labeler is the world's) and returns plain values and PNG
bytes; the MCP layer only shapes them."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from fleet.core import ServiceCore
from sim.errors import ErrorCode, FleetError
from sim.perception import (
    SensorHealthMonitor,
    annotate_detections,
    cluster_obstacles,
    depth_to_points,
    detect_objects,
    extrinsics_from_image,
    fit_ground_plane,
    label_map_png,
    label_pixels,
    overlay_png,
    remove_ground,
    statistical_outlier_removal,
    voxel_filter,
)
from sim.types import LidarScan

SCAN_OPERATIONS = ("clusters", "voxel_filter", "outlier_removal", "ground_removal")


class PerceptionOps(ServiceCore):
    """Mixed into FleetService."""

    def _init_perception_ops(self) -> None:
        self._health: SensorHealthMonitor | None = None
        self._health_since = 0.0
        self._health_robots: set[str] = set()

    def detect_objects(self, robot: str, *, min_pixels: int = 20, group_by: str = "model") -> dict[str, Any]:
        """Render the robot's camera now and detect every visible model: box, pixels, distance, 3-D position.
        Returns {detections, png (annotated image), image: {...}}."""

        def do() -> dict[str, Any]:
            self.registry.get(robot)
            img = self.world.render_camera(robot)
            dets = detect_objects(img, self.world.body_label, min_pixels=min_pixels, group_by=group_by,  # type: ignore[arg-type]
                                  exclude=("ground_plane", robot))
            return {"detections": [{"label": d.label, "model": d.model, "box": list(d.box), "pixels": d.pixel_count,
                                    "distance": _r(d.distance), "position": _r3(d.position)} for d in dets],
                    "png": annotate_detections(img, dets), "image": _image_meta(img)}

        return self.call(do)

    def segment_image(self, robot: str) -> dict[str, Any]:
        """Render the camera and label every pixel with its model (instance segmentation by model/link)."""

        def do() -> dict[str, Any]:
            self.registry.get(robot)
            img = self.world.render_camera(robot, depth=False)
            assert img.segmentation is not None
            lm = label_pixels(img.segmentation, self.world.body_label)
            counts = np.bincount(lm.ids[lm.ids >= 0].ravel(), minlength=len(lm.labels))
            total = lm.ids.size
            order = np.argsort(-counts, kind="stable")
            classes: list[dict[str, Any]] = [
                {"model": lm.labels[i][0], "link": lm.labels[i][1], "pixels": int(counts[i]),
                 "fraction": round(int(counts[i]) / total, 4)} for i in order if counts[i] > 0]
            return {"classes": classes, "background_fraction": round(float((lm.ids < 0).mean()), 4),
                    "png": label_map_png(lm), "image": _image_meta(img)}

        return self.call(do)

    def lidar_camera_overlay(self, robot: str) -> dict[str, Any]:
        """The latest scan projected into a camera image rendered now (fusion of lidar and camera)."""

        def do() -> dict[str, Any]:
            self.registry.get(robot)
            scan = self._scan(robot)
            img = self.world.render_camera(robot, segmentation=False)
            extr = extrinsics_from_image(img, self.world.robot_pose(robot), self.world.robot_spec(robot))
            png, proj = overlay_png(img, scan, extr)
            return {"png": png, "image": _image_meta(img), "returns": int(np.isfinite(scan.ranges).sum()),
                    "projected": len(proj.beams), "scan_stamp": scan.stamp,
                    "depth_range": [_r(float(proj.depth.min())), _r(float(proj.depth.max()))] if len(proj.depth)
                    else None}

        return self.call(do)

    def process_scan(self, robot: str, operation: str = "clusters", *, eps: float = 0.15, min_points: int = 3,
                     voxel: float = 0.1, k: int = 8, std_ratio: float = 2.0) -> dict[str, Any]:
        """Process the latest lidar scan (in the map frame): clusters (Euclidean obstacles), voxel_filter,
        outlier_removal; or ground_removal on a depth-camera cloud rendered now (RANSAC plane)."""
        if operation not in SCAN_OPERATIONS:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"unknown operation '{operation}'",
                             f"operations: {', '.join(SCAN_OPERATIONS)}")

        def do() -> dict[str, Any]:
            self.registry.get(robot)
            if operation == "ground_removal":
                img = self.world.render_camera(robot, which="depth", rgb=False, segmentation=False)
                cloud = depth_to_points(img, stride=2)
                if len(cloud) < 3:
                    raise FleetError(ErrorCode.NOT_FOUND, "the depth image has no valid returns",
                                     "turn the robot towards something within the depth camera's range")
                plane = fit_ground_plane(cloud, rng=self.world.rng)
                rest = remove_ground(cloud, plane, min_height=0.02)
                return {"operation": operation, "input_points": len(cloud), "ground_points": int(plane.inliers.sum()),
                        "remaining_points": len(rest), "plane": {"normal": _r3(plane.normal), "d": _r(plane.d)}}
            scan = self._scan(robot)
            mast_x = self.world.robot_spec(robot).mast.x_offset
            pts = _scan_in_map(scan, self.world.robot_pose(robot).as_tuple(), mast_x)
            out: dict[str, Any] = {"operation": operation, "input_points": len(pts), "scan_stamp": scan.stamp}
            if operation == "clusters":
                obs = cluster_obstacles(pts, eps=eps, min_points=min_points)
                out["obstacles"] = [{"centre": _r3(o.centre), "extent": _r3(o.extent), "points": o.count,
                                     "radius": _r(o.radius)} for o in obs[:100]]
                out["count"] = len(obs)
            elif operation == "voxel_filter":
                out["output_points"] = len(voxel_filter(pts, voxel))
            else:
                out["output_points"] = len(statistical_outlier_removal(pts, k=k, std_ratio=std_ratio))
            return out

        return self.call(do)

    def sensor_health(self, robot: str | None = None) -> dict[str, Any]:
        """Rate, latency, dropouts, noise and a quality score per sensor stream, with alerts. Monitoring starts
        at the first call (and for robots spawned since): rates need a second or two of sim time."""

        def do() -> dict[str, Any]:
            if robot is not None:
                self.registry.get(robot)
            if self._health is None:
                self._health = SensorHealthMonitor()
                self._health.attach(self.world)
                self._health_since = self.world.time
            for r in self.world.robot_names():
                if r not in self._health_robots:
                    self._health.add_robot(r, self.world.robot_spec(r))
                    self._health_robots.add(r)
            now = self.world.time
            rep = self._health.report(now)
            streams = [h for name, h in rep.items() if (robot is None or name.startswith(f"{robot}/"))
                       and name.split("/")[0] in self.world.robot_names()]
            return {"monitoring_since": self._health_since, "streams": [
                {"stream": h.stream, "configured_hz": h.configured_hz, "measured_hz": _r(h.measured_hz),
                 "latency_mean_s": _r(h.latency_mean), "dropouts": h.dropouts, "longest_gap_s": _r(h.longest_gap),
                 "silent_for_s": _r(h.silent_for), "noise_std": _r(h.noise_std), "quality": _r(h.quality),
                 "alerts": [{"kind": a.kind, "message": a.message} for a in h.alerts]} for h in streams]}

        return self.call(do)

    def _scan(self, robot: str) -> LidarScan:
        scan = self.world.latest_scan(robot)
        if scan is None:
            raise FleetError(ErrorCode.NOT_FOUND, f"no lidar scan from '{robot}' yet", "step the simulation first")
        return scan


def _scan_in_map(scan: LidarScan, pose: tuple[float, float, float], mast_x: float) -> np.ndarray:
    """Valid returns as (k, 2) map-frame points (the lidar sits `mast_x` ahead of base_link, not rotated)."""
    x, y, yaw = pose
    p = scan.points() + np.array([mast_x, 0.0])
    c, s = math.cos(yaw), math.sin(yaw)
    return np.column_stack([x + c * p[:, 0] - s * p[:, 1], y + s * p[:, 0] + c * p[:, 1]])


def _image_meta(img: Any) -> dict[str, Any]:
    cp = img.camera_pose
    return {"robot": img.robot, "stamp": img.stamp, "width": img.width, "height": img.height, "fov_deg": img.fov_deg,
            "camera_pose": {"x": _r(cp.x), "y": _r(cp.y), "z": _r(cp.z), "yaw": _r(cp.yaw)}}


def _r(x: float | None) -> float | None:
    return None if x is None or not math.isfinite(x) else round(float(x), 4)


def _r3(v: Any) -> list[float | None] | None:
    return None if v is None else [_r(float(a)) for a in v]
