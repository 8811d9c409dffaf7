"""Segmentation labels and detections against a PyBullet scene whose boxes are known exactly."""

from __future__ import annotations

import io
import math
from collections.abc import Iterator

import numpy as np
import pytest
from PIL import Image

from sim.errors import FleetError
from sim.perception import (
    annotate_detections,
    decode_mask,
    depth_to_points,
    detect_objects,
    label_map_png,
    label_pixels,
)
from sim.types import Pose3D
from tests.sim.perception.pb_scene import Scene, box_corners, distance_to_box, gl_project

W, H, FOV = 160, 120, 60.0


@pytest.fixture(scope="module")
def scene() -> Iterator[Scene]:
    s = Scene()
    s.add_ground()
    s.add_box("front", Pose3D(4.0, 0.0, 0.5), (1.0, 1.0, 1.0))  # face-on, camera at its mid-height
    s.add_box("left", Pose3D(5.0, 2.0, 0.4, 0, 0, 0.5), (0.6, 0.8, 0.8), rgba=(0.2, 0.7, 0.2, 1))
    s.add_box("speck", Pose3D(20.0, -4.0, 0.5), (0.1, 0.1, 0.1))  # ≈ 1 px at 20 m
    s.add_two_link("stack", (5.0, -2.0, 0.25), 0.5)
    yield s
    s.close()


CAM = Pose3D(0.0, 0.0, 0.5)


def test_mask_decoding_handles_link_and_plain_encodings(scene: Scene) -> None:
    with_links = scene.render(CAM, W, H, FOV, link_flag=True)
    plain = scene.render(CAM, W, H, FOV, link_flag=False)
    assert with_links.segmentation is not None and plain.segmentation is not None
    uid_l, link_l = decode_mask(with_links.segmentation)
    uid_p, link_p = decode_mask(plain.segmentation)
    np.testing.assert_array_equal(uid_l, uid_p)  # same bodies either way
    assert set(np.unique(link_p)) <= {-1}  # a plain uid reads as the base link
    stack_uid = next(u for u, (n, _) in scene.names.items() if n == "stack")
    assert {0, -1} <= set(np.unique(link_l[uid_l == stack_uid]).tolist())  # top link and base both seen
    lm = label_pixels(with_links.segmentation, scene.labeler)
    assert {("stack", "top"), ("stack", "base"), ("front", "base")} <= set(lm.labels)


def test_detection_box_matches_projected_corners(scene: Scene) -> None:
    image = scene.render(CAM, W, H, FOV)
    dets = {d.label: d for d in detect_objects(image, scene.labeler, exclude=("ground_plane",))}
    for name in ("front", "left"):
        pose, size = scene.boxes[name]
        uv = gl_project(box_corners(pose, size), CAM, W, H, FOV)
        # TinyRenderer fills pixel (i, j) when the ideal point (i − ½, j + ½) is inside the silhouette.
        expected = (math.ceil(uv[:, 0].min() + 0.5), math.ceil(uv[:, 1].min() - 0.5),
                    math.floor(uv[:, 0].max() + 0.5), math.floor(uv[:, 1].max() - 0.5))
        assert dets[name].box == expected, (name, dets[name].box, expected)


def test_distance_and_position_of_a_face_on_box(scene: Scene) -> None:
    image = scene.render(CAM, W, H, FOV)
    det = next(d for d in detect_objects(image, scene.labeler) if d.label == "front")
    # Only the front face (x = 3.5) is visible: every depth is 3.5 m and its centre is (3.5, 0, 0.5).
    assert det.distance == pytest.approx(3.5, abs=0.01)
    assert det.position is not None
    assert np.allclose(det.position, (3.5, 0.0, 0.5), atol=0.005)
    # The pixel count is the face's projected area: (f·1/3.5)² with f = (W/2)/tan(FOV/2).
    f = 0.5 * W / math.tan(math.radians(FOV / 2))
    assert det.pixel_count == pytest.approx((f / 3.5) ** 2, rel=0.06)


def test_back_projected_depth_lies_on_the_box_surfaces_from_a_tilted_camera(scene: Scene) -> None:
    cam = Pose3D(1.0, 0.5, 1.2, 0.0, math.radians(12), math.radians(-8))  # pitched down, yawed right
    image = scene.render(cam, W, H, FOV)
    assert image.segmentation is not None and image.depth is not None
    lm = label_pixels(image.segmentation, scene.labeler)
    pts = depth_to_points(image)  # row-major over valid pixels, same order as np.nonzero below
    valid = np.isfinite(image.depth) & (image.depth < image.far)
    ids = lm.ids[valid]
    for name in ("front", "left"):
        k = lm.labels.index((name, "base"))
        pose, size = scene.boxes[name]
        d = distance_to_box(pts[ids == k], pose, size)
        assert d.size > 50 and np.percentile(d, 95) < 0.005, (name, np.percentile(d, 95))
    det = next(x for x in detect_objects(image, scene.labeler) if x.label == "front")
    assert det.position is not None
    pose, size = scene.boxes["front"]
    assert distance_to_box(np.array([det.position]), pose, size)[0] < 0.05  # a point on the visible surface


def test_visibility_threshold_and_exclusion(scene: Scene) -> None:
    image = scene.render(CAM, W, H, FOV)
    default = {d.label for d in detect_objects(image, scene.labeler, min_pixels=20, exclude=("ground_plane",))}
    assert default == {"front", "left", "stack"}  # the speck (≈1 px) is below the threshold
    everything = {d.label for d in detect_objects(image, scene.labeler, min_pixels=1)}
    assert everything == {"front", "left", "stack", "speck", "ground_plane"}
    by_link = {d.label for d in detect_objects(image, scene.labeler, group_by="link", exclude=("ground_plane",))}
    assert {"stack/base", "stack/top"} <= by_link


def test_annotated_png_has_the_boxes_drawn(scene: Scene) -> None:
    image = scene.render(CAM, W, H, FOV)
    dets = detect_objects(image, scene.labeler, exclude=("ground_plane",))
    png = Image.open(io.BytesIO(annotate_detections(image, dets)))
    assert png.size == (W, H)
    arr = np.asarray(png.convert("RGB")).astype(int)
    changed = np.any(arr != image.rgb, axis=2)
    u0, v0, u1, v1 = dets[0].box
    assert changed[v0 + (v1 - v0) // 2, u0] and changed[v0 + (v1 - v0) // 2, u1]  # box outline on both sides
    assert image.segmentation is not None
    seg_png = Image.open(io.BytesIO(label_map_png(label_pixels(image.segmentation, scene.labeler))))
    assert seg_png.size == (W, H)


def test_missing_segmentation_is_a_clear_error(scene: Scene) -> None:
    image = scene.render(CAM, W, H, FOV)
    from dataclasses import replace

    with pytest.raises(FleetError, match="segmentation"):
        detect_objects(replace(image, segmentation=None), scene.labeler)
