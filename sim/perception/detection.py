"""Camera detections from the segmentation buffer: one per visible model (or link), with depth and 3D place.

Recipe per label: pixels → 2D box and count → visibility threshold → median depth of the valid depth
pixels (the distance) → those pixels back-projected through the intrinsics and the camera pose → the
per-axis median (robust to silhouette pixels whose depth falls on the background).
"""

from __future__ import annotations

from collections.abc import Collection
from typing import Literal

import numpy as np

from sim.errors import ErrorCode, FleetError
from sim.perception.projection import backproject, intrinsics_of, transform_points, valid_depth
from sim.perception.segmentation import label_pixels
from sim.perception.types import Detection, Labeler, LabelMap
from sim.types import CameraImage

GroupBy = Literal["model", "link"]


def detect_objects(image: CameraImage, labeler: Labeler, *, min_pixels: int = 20,
                   group_by: GroupBy = "model", exclude: Collection[str] = ()) -> list[Detection]:
    """Detections in `image`, largest first. Models named in `exclude` (e.g. the ground plane or the
    robot carrying the camera) are skipped; objects with fewer than `min_pixels` pixels are not visible."""
    if image.segmentation is None:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, "the camera image has no segmentation buffer",
                         "render it with segmentation=True")
    if min_pixels < 1 or group_by not in ("model", "link"):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"bad min_pixels={min_pixels} or group_by={group_by!r}",
                         "min_pixels ≥ 1; group_by is 'model' or 'link'")
    if image.depth is not None and np.shape(image.depth) != np.shape(image.segmentation):
        raise FleetError(ErrorCode.INVALID_ARGUMENT,
                         f"depth {np.shape(image.depth)} and segmentation "
                         f"{np.shape(image.segmentation)} differ",
                         "render both channels in one call")
    lm = label_pixels(image.segmentation, labeler)
    groups = _groups(lm, group_by, set(exclude))
    depth_ok = valid_depth(image) if image.depth is not None else None
    out = []
    for label, (model, ids) in groups.items():
        mask = np.isin(lm.ids, ids)
        count = int(mask.sum())
        if count < min_pixels:
            continue
        links = tuple(sorted({lm.labels[i][1] for i in ids}))
        out.append(_detection(image, label, model, links, mask, count, depth_ok))
    out.sort(key=lambda d: (-d.pixel_count, d.label))
    return out


def _groups(lm: LabelMap, group_by: GroupBy, exclude: set[str]) -> dict[str, tuple[str, list[int]]]:
    groups: dict[str, tuple[str, list[int]]] = {}
    for i, (model, link) in enumerate(lm.labels):
        if not model or model in exclude:  # "" is a body the labeler does not know
            continue
        key = model if group_by == "model" else f"{model}/{link}"
        groups.setdefault(key, (model, []))[1].append(i)
    return groups


def _detection(image: CameraImage, label: str, model: str, links: tuple[str, ...], mask: np.ndarray,
               count: int, depth_ok: np.ndarray | None) -> Detection:
    vs, us = np.nonzero(mask)
    box = (int(us.min()), int(vs.min()), int(us.max()), int(vs.max()))
    distance: float | None = None
    position: tuple[float, float, float] | None = None
    if depth_ok is not None and image.depth is not None:
        sel = mask & depth_ok
        if sel.any():
            vv, uu = np.nonzero(sel)
            d = np.asarray(image.depth, dtype=float)[vv, uu]
            distance = float(np.median(d))
            world = transform_points(image.camera_pose, backproject(uu, vv, d, intrinsics_of(image)))
            med = np.median(world, axis=0)
            position = (float(med[0]), float(med[1]), float(med[2]))
    return Detection(label, model, links, box, count, distance, position)
