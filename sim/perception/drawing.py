"""PNG renderings of perception results (Pillow): annotated detections, label maps, lidar overlays."""

from __future__ import annotations

import colorsys
import io
from collections.abc import Sequence

import numpy as np
from PIL import Image, ImageDraw

from sim.perception.types import Detection, LabelMap
from sim.types import CameraImage


def label_colour(i: int) -> tuple[int, int, int]:
    """A distinct, stable colour per index (golden-ratio hue steps)."""
    r, g, b = colorsys.hsv_to_rgb((i * 0.618034) % 1.0, 0.85, 0.95)
    return (int(255 * r), int(255 * g), int(255 * b))


def base_image(image: CameraImage) -> Image.Image:
    """The RGB channel, or the depth channel as grey (near = bright) when the image has no RGB."""
    if image.rgb is not None:
        return Image.fromarray(np.ascontiguousarray(np.asarray(image.rgb)[..., :3], dtype=np.uint8), "RGB")
    if image.depth is not None:
        d = np.asarray(image.depth, dtype=float)
        ok = np.isfinite(d)
        grey = np.zeros(d.shape, dtype=np.uint8)
        if ok.any():
            lo, hi = float(d[ok].min()), float(d[ok].max())
            grey[ok] = (255 * (1 - (d[ok] - lo) / max(hi - lo, 1e-9))).astype(np.uint8)
        return Image.fromarray(grey, "L").convert("RGB")
    return Image.new("RGB", (image.width, image.height))


def to_png(img: Image.Image) -> bytes:
    buf = io.BytesIO()
    img.save(buf, format="PNG")
    return buf.getvalue()


def annotate_detections(image: CameraImage, detections: Sequence[Detection]) -> bytes:
    """The camera image with each detection's box and a caption (label, distance) drawn on it, as PNG."""
    img = base_image(image)
    draw = ImageDraw.Draw(img)
    for i, det in enumerate(detections):
        colour = label_colour(i)
        draw.rectangle(det.box, outline=colour, width=2)
        caption = det.label if det.distance is None else f"{det.label} {det.distance:.2f} m"
        x, y = det.box[0], max(0, det.box[1] - 12)
        draw.rectangle(draw.textbbox((x, y), caption), fill=(0, 0, 0))
        draw.text((x, y), caption, fill=colour)
    return to_png(img)


def label_map_png(lm: LabelMap) -> bytes:
    """Each label in its own colour, background black, as PNG."""
    palette = np.array([label_colour(i) for i in range(max(1, len(lm.labels)))], dtype=np.uint8)
    rgb = np.zeros((*lm.ids.shape, 3), dtype=np.uint8)
    fg = lm.ids >= 0
    rgb[fg] = palette[lm.ids[fg]]
    return to_png(Image.fromarray(rgb, "RGB"))


def draw_points(image: CameraImage, uv: np.ndarray, depth: np.ndarray, max_depth: float,
                radius: int = 2) -> bytes:
    """Projected points drawn as dots coloured by depth (red near → blue far) on the camera image."""
    img = base_image(image)
    draw = ImageDraw.Draw(img)
    for (u, v), d in zip(np.asarray(uv, dtype=float), np.asarray(depth, dtype=float), strict=True):
        t = min(max(d / max(max_depth, 1e-9), 0.0), 1.0)
        r, g, b = colorsys.hsv_to_rgb(0.66 * t, 1.0, 1.0)
        draw.ellipse((u - radius, v - radius, u + radius, v + radius), fill=(int(255 * r), int(255 * g),
                                                                            int(255 * b)))
    return to_png(img)
