"""ROS map_server maps: a PGM/PNG image plus a YAML file (image, resolution, origin, negate, thresholds, mode).

Reading follows nav2 map_io: a pixel's occupancy is p = (255 - v) / 255 (or v / 255 when `negate`);
trinary mode gives 100 above occupied_thresh, 0 below free_thresh, unknown (-1) between; scale mode
keeps the in-between as a percentage; raw mode takes the pixel value itself (> 100 is unknown).
Writing uses map_saver's trinary encoding (0 occupied, 254 free, 205 unknown) with the thresholds
0.65 / 0.196, so a saved map loads back to exactly the same grid.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Literal

import numpy as np
import yaml
from PIL import Image
from pydantic import Field, model_validator

from planning.grid import OCCUPIED, UNKNOWN_CELL, OccupancyGrid
from sim.config import StrictModel, load_yaml
from sim.errors import ErrorCode, FleetError

_SAVE_OCCUPIED_THRESH = 0.65
_SAVE_FREE_THRESH = 0.196  # 205 (unknown) has p = 0.19608, just above it


class MapYaml(StrictModel):
    image: str
    resolution: float = Field(gt=0)
    origin: tuple[float, float, float]
    negate: int = Field(0, ge=0, le=1)
    occupied_thresh: float = Field(0.65, ge=0, le=1)
    free_thresh: float = Field(0.196, ge=0, le=1)
    mode: Literal["trinary", "scale", "raw"] = "trinary"

    @model_validator(mode="after")
    def _thresholds(self) -> MapYaml:
        if self.free_thresh >= self.occupied_thresh:
            raise ValueError("free_thresh must be below occupied_thresh")
        return self


def load_map(yaml_path: str | Path) -> OccupancyGrid:
    """Read a map_server YAML and its image into an OccupancyGrid (row 0 = bottom of the image)."""
    path = Path(yaml_path)
    meta = load_yaml(path, MapYaml)
    if abs(meta.origin[2]) > 1e-12:
        raise FleetError(ErrorCode.UNSUPPORTED, f"{path}: origin yaw {meta.origin[2]} is not 0",
                         "rotate the map image so the origin yaw is 0 (most ROS tools ignore it too)")
    img_path = Path(meta.image) if Path(meta.image).is_absolute() else path.parent / meta.image
    try:
        with Image.open(img_path) as im:
            pixels = _to_gray(im)
    except OSError as exc:
        raise FleetError(ErrorCode.NOT_FOUND, f"{path}: cannot read map image {img_path}: {exc}",
                         "check the 'image' field (relative paths are relative to the YAML file)") from exc
    data = _pixels_to_occupancy(pixels, meta)
    return OccupancyGrid(np.flipud(data), meta.resolution, (meta.origin[0], meta.origin[1]))


def save_map(grid: OccupancyGrid, yaml_path: str | Path, image_format: Literal["pgm", "png"] = "pgm") -> Path:
    """Write `<name>.yaml` and `<name>.pgm` (trinary, like map_saver). Returns the YAML path."""
    path = Path(yaml_path)
    img_path = path.with_suffix("." + image_format)
    occ = grid.data >= math.ceil(_SAVE_OCCUPIED_THRESH * 100)
    free = (grid.data >= 0) & (grid.data <= _SAVE_FREE_THRESH * 100)
    pixels = np.full(grid.data.shape, 205, dtype=np.uint8)
    pixels[free] = 254
    pixels[occ] = 0
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(np.ascontiguousarray(np.flipud(pixels)), mode="L").save(img_path)
    meta = {"image": img_path.name, "mode": "trinary", "resolution": grid.resolution,
            "origin": [grid.origin[0], grid.origin[1], 0.0], "negate": 0,
            "occupied_thresh": _SAVE_OCCUPIED_THRESH, "free_thresh": _SAVE_FREE_THRESH}
    path.write_text(yaml.safe_dump(meta, sort_keys=False), encoding="utf-8")
    return path


def _to_gray(im: Image.Image) -> np.ndarray:
    """Mean of the colour channels (alpha ignored), as map_server does; 8-bit range."""
    if im.mode in ("I", "I;16", "I;16B"):  # 16-bit PGM: scale to 8 bits
        return np.asarray(im, dtype=np.float64) / 257.0
    rgb = im.convert("RGBA") if im.mode in ("P", "LA", "PA") else im
    arr = np.asarray(rgb, dtype=np.float64)
    if arr.ndim == 3:
        arr = arr[..., :3].mean(axis=2) if arr.shape[2] >= 3 else arr[..., 0]
    return arr


def _pixels_to_occupancy(pixels: np.ndarray, meta: MapYaml) -> np.ndarray:
    if meta.mode == "raw":
        out = np.where(pixels <= 100, pixels, UNKNOWN_CELL)
        return out.astype(np.int8)
    p = pixels / 255.0 if meta.negate else (255.0 - pixels) / 255.0
    out = np.full(pixels.shape, UNKNOWN_CELL, dtype=np.int8)
    if meta.mode == "scale":
        mid = (p >= meta.free_thresh) & (p <= meta.occupied_thresh)
        scaled = np.rint((p - meta.free_thresh) / (meta.occupied_thresh - meta.free_thresh) * 100.0)
        out[mid] = scaled[mid].astype(np.int8)
    out[p > meta.occupied_thresh] = OCCUPIED
    out[p < meta.free_thresh] = 0
    return out
