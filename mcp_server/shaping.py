"""Shaping answers for assistants: every answer carries sim time; big arrays are summarised unless asked for."""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, Field, model_validator

from fleet.types import FleetSnapshot
from sim.types import LidarScan

ResponseFormat = Literal["summary", "normal", "full"]


class Answer(BaseModel):
    """Base of every structured answer."""

    sim_time: float = Field(description="simulation time of the answer, s")

    @model_validator(mode="before")
    @classmethod
    def _plain(cls, data: Any) -> Any:
        """Service results may hold numpy scalars/arrays and non-finite floats: make them plain JSON values."""
        return jsonable(data) if isinstance(data, dict) else data


def jsonable(v: Any) -> Any:
    """numpy → Python, non-finite floats → None, tuples → lists; pydantic models are left alone."""
    if isinstance(v, BaseModel):
        return v
    if isinstance(v, dict):
        return {str(k): jsonable(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [jsonable(x) for x in v]
    if isinstance(v, np.ndarray):
        return jsonable(v.tolist())
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


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


def compress_names(names: Sequence[str], max_chars: int = 300) -> str:
    """'robot1..robot100, scout2, scout5' for long fleets: runs of numbered names become ranges."""
    runs: dict[str, list[int]] = {}
    plain: list[str] = []
    for n in names:
        m = re.fullmatch(r"(.*?)(\d+)", n)
        if m and not (len(m.group(2)) > 1 and m.group(2).startswith("0")):
            runs.setdefault(m.group(1), []).append(int(m.group(2)))
        else:
            plain.append(n)
    parts: list[str] = []
    for prefix, nums in runs.items():
        nums.sort()
        start = prev = nums[0]
        for k in [*nums[1:], None]:
            if k is not None and k == prev + 1:
                prev = k
                continue
            parts.append(f"{prefix}{start}" if start == prev else f"{prefix}{start}..{prefix}{prev}")
            if k is not None:
                start = prev = k
    parts += plain
    text = ", ".join(parts)
    if len(text) > max_chars:
        cut = text[:max_chars].rsplit(", ", 1)[0]
        text = f"{cut}, … (+{len(parts) - cut.count(', ') - 1} more groups)"
    return text


def fleet_summary(snap: FleetSnapshot, low_battery: float = 0.2, attention: int = 10) -> dict[str, Any]:
    """Counts and aggregates for the whole fleet (never one line per robot), the names as ranges, and the few
    robots that need attention (e-stopped, in collision, low battery)."""
    s = snap.summary()
    s.pop("time", None)
    s["names"] = compress_names(snap.names)
    masks = {"estopped": np.asarray(snap.estopped, dtype=bool), "collision": np.asarray(snap.in_collision, dtype=bool),
             "low_battery": np.asarray(snap.battery) < low_battery}
    any_issue = np.logical_or.reduce(list(masks.values())) if len(snap.names) else np.zeros(0, dtype=bool)
    flagged = [{"name": snap.names[i], "issues": [k for k, m in masks.items() if m[i]]}
               for i in np.flatnonzero(any_issue)]
    s["attention"] = flagged[:attention]
    if len(flagged) > attention:
        s["attention_more"] = len(flagged) - attention
    if len(snap.names):
        lo, hi = snap.pose[:, :2].min(axis=0), snap.pose[:, :2].max(axis=0)
        s["extent"] = [r3(float(v)) for v in (*lo, *hi)]
    return s


def path_payload(path: np.ndarray, fmt: ResponseFormat, tolerance: float = 0.05) -> dict[str, Any]:
    """A path as a Douglas–Peucker polyline within `tolerance` m of the original (summary: endpoints only;
    full: every point)."""
    pts = np.asarray(path, dtype=float).reshape(-1, 2)
    d: dict[str, Any] = {"points": len(pts)}
    if fmt == "summary" or len(pts) == 0:
        d["ends"] = [[r3(float(x)), r3(float(y))] for x, y in pts[[0, -1]]] if len(pts) else []
        return d
    if fmt == "full":
        d["polyline"] = [[r3(float(x)), r3(float(y))] for x, y in pts]
        return d
    simple = simplify_polyline(pts, tolerance)
    d["polyline"] = [[r3(float(x)), r3(float(y))] for x, y in simple]
    d["simplified_tolerance_m"] = tolerance
    return d

# The `overwrite` parameter of every tool that writes a file (files the server wrote itself need no flag).
OVERWRITE = Field(False, description="replace an existing file this server did not write")
