"""Shaping answers for assistants: every answer carries sim time; big arrays are summarised unless asked for."""

from __future__ import annotations

import math
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, Field

from sim.types import LidarScan

ResponseFormat = Literal["summary", "normal", "full"]


class Answer(BaseModel):
    """Base of every structured answer."""

    sim_time: float = Field(description="simulation time of the answer, s")


def r3(x: float) -> float | None:
    return round(float(x), 3) if math.isfinite(x) else None


def sector_minima(scan: LidarScan, sectors: int = 8) -> list[dict[str, Any]]:
    """Closest return per equal angular sector, sector 0 centred straight ahead, counter-clockwise."""
    angles = (scan.angles() + np.pi / sectors) % (2 * np.pi)  # shift so sector 0 is centred on 0 rad
    idx = np.minimum((angles / (2 * np.pi / sectors)).astype(int), sectors - 1)
    out = []
    names = {8: ["front", "front_left", "left", "rear_left", "rear", "rear_right", "right", "front_right"]}
    for k in range(sectors):
        r = scan.ranges[idx == k]
        r = r[np.isfinite(r)]
        label = names.get(sectors, [f"sector{i}" for i in range(sectors)])[k]
        out.append({"sector": label, "min_range": r3(float(r.min())) if r.size else None})
    return out


def simplify_polyline(points: np.ndarray, tolerance: float) -> np.ndarray:
    """Douglas–Peucker: the simplified polyline stays within `tolerance` metres of the original."""
    pts = np.asarray(points, dtype=float)
    if len(pts) < 3:
        return pts
    keep = np.zeros(len(pts), dtype=bool)
    keep[0] = keep[-1] = True
    stack = [(0, len(pts) - 1)]
    while stack:
        a, b = stack.pop()
        seg = pts[b] - pts[a]
        norm = float(np.hypot(*seg))
        rel = pts[a + 1:b] - pts[a]
        d = np.abs(seg[0] * rel[:, 1] - seg[1] * rel[:, 0]) / norm if norm > 0 else np.hypot(rel[:, 0], rel[:, 1])
        if d.size and float(d.max()) > tolerance:
            k = a + 1 + int(np.argmax(d))
            keep[k] = True
            stack += [(a, k), (k, b)]
    return pts[keep]


def scan_payload(scan: LidarScan, fmt: ResponseFormat) -> dict[str, Any]:
    finite = scan.ranges[np.isfinite(scan.ranges)]
    d: dict[str, Any] = {"stamp": scan.stamp, "beams": int(scan.ranges.size), "returns": int(finite.size),
                         "min_range": r3(float(finite.min())) if finite.size else None,
                         "sector_minima": sector_minima(scan)}
    if fmt == "full":
        d["angle_min"] = scan.angle_min
        d["angle_increment"] = scan.angle_increment
        d["ranges"] = [r3(float(r)) for r in scan.ranges]
    return d
