"""Debug markers: shapes an operator or an assistant draws into the world's live view (the map image) and
into recordings (each change is an event on the bus, which recorders log). They live in sim time and may
expire; they never touch physics."""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from sim.errors import ErrorCode, FleetError

MARKER_KINDS = ("point", "line", "arrow", "path", "polygon", "box", "circle", "text")
MIN_POINTS = {"point": 1, "text": 1, "circle": 1, "line": 2, "arrow": 2, "path": 2, "box": 2, "polygon": 3}
COLOURS: dict[str, tuple[int, int, int]] = {
    "red": (220, 40, 40), "green": (30, 160, 60), "blue": (30, 120, 220), "yellow": (230, 200, 0),
    "orange": (240, 140, 0), "purple": (150, 60, 200), "cyan": (0, 170, 170), "magenta": (210, 0, 160),
    "black": (0, 0, 0), "white": (255, 255, 255), "grey": (128, 128, 128)}
MAX_MARKERS = 2000
MAX_POINTS = 5000

XY = tuple[float, float]


@dataclass(frozen=True, slots=True)
class DebugMarker:
    """`points` in the map frame: one for point/text/circle (centre), two for line/arrow (from, to) and box
    (opposite corners), two or more for a path, three or more for a polygon. `size` is the line width or
    point/circle radius in metres."""

    id: str
    kind: str
    points: tuple[XY, ...]
    colour: tuple[int, int, int]
    size: float
    text: str
    ns: str
    created: float
    expires: float | None  # sim time; None: until cleared

    def to_dict(self) -> dict[str, Any]:
        return {"id": self.id, "kind": self.kind, "points": [[round(x, 4), round(y, 4)] for x, y in self.points],
                "colour": list(self.colour), "size": self.size, "text": self.text, "ns": self.ns,
                "created": round(self.created, 4), "expires": None if self.expires is None else round(self.expires, 4)}


def parse_colour(colour: str | Sequence[int]) -> tuple[int, int, int]:
    if isinstance(colour, str):
        if colour in COLOURS:
            return COLOURS[colour]
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"unknown colour '{colour}'",
                         f"colours: {', '.join(COLOURS)}, or [r, g, b] with 0..255")
    rgb = tuple(int(c) for c in colour)
    if len(rgb) != 3 or not all(0 <= c <= 255 for c in rgb):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"colour must be [r, g, b] in 0..255, got {list(colour)}")
    return (rgb[0], rgb[1], rgb[2])


class MarkerStore:
    """The markers of one world, by id; expired ones are dropped when read."""

    def __init__(self) -> None:
        self._ids = itertools.count(1)
        self.markers: dict[str, DebugMarker] = {}

    def add(self, kind: str, points: Sequence[Sequence[float]], *, now: float, colour: str | Sequence[int] = "red",
            size: float = 0.05, text: str = "", ns: str = "default", lifetime_s: float | None = None) -> DebugMarker:
        if kind not in MARKER_KINDS:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"unknown marker kind '{kind}'",
                             f"kinds: {', '.join(MARKER_KINDS)}")
        pts = tuple((float(p[0]), float(p[1])) for p in points if len(p) >= 2)
        if len(pts) != len(points) or not all(math.isfinite(v) for p in pts for v in p):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, "marker points must be finite [x, y] pairs")
        if not MIN_POINTS[kind] <= len(pts) <= MAX_POINTS:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"a {kind} marker needs {MIN_POINTS[kind]}.."
                             f"{MAX_POINTS} points, got {len(pts)}")
        if kind in ("line", "arrow", "box") and len(pts) != 2:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"a {kind} marker takes exactly 2 points (from, to)")
        if not (math.isfinite(size) and 0 < size <= 100):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"size must be in (0, 100] m, got {size}")
        if lifetime_s is not None and not (math.isfinite(lifetime_s) and lifetime_s > 0):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"lifetime_s must be > 0, got {lifetime_s}")
        self.prune(now)
        if len(self.markers) >= MAX_MARKERS:
            raise FleetError(ErrorCode.LIMIT_EXCEEDED, f"{MAX_MARKERS} markers exist already",
                             "clear some with clear_debug_markers")
        m = DebugMarker(f"m{next(self._ids)}", kind, pts, parse_colour(colour), float(size), text[:200], ns, now,
                        None if lifetime_s is None else now + lifetime_s)
        self.markers[m.id] = m
        return m

    def clear(self, marker_id: str | None = None, ns: str | None = None) -> list[str]:
        if marker_id is not None:
            if marker_id not in self.markers:
                raise FleetError(ErrorCode.NOT_FOUND, f"no marker '{marker_id}'",
                                 f"markers: {', '.join(list(self.markers)[-10:]) or 'none'}")
            del self.markers[marker_id]
            return [marker_id]
        gone = [i for i, m in self.markers.items() if ns is None or m.ns == ns]
        for i in gone:
            del self.markers[i]
        return gone

    def prune(self, now: float) -> None:
        for i in [i for i, m in self.markers.items() if m.expires is not None and m.expires <= now]:
            del self.markers[i]

    def active(self, now: float, ns: str | None = None) -> list[DebugMarker]:
        self.prune(now)
        return [m for m in self.markers.values() if ns is None or m.ns == ns]
