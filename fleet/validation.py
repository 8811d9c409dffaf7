"""Bounded, finite inputs: the one place every front door (MCP, Zenoh, missions, Python) checks numbers before
anything reaches the sim thread.

Two layers. The pydantic types (`Coord`, `Yaw`, `Steps`, `Speed`, `XY`, `Polygon`, ...) reject NaN, ±inf and
absurd magnitudes at the schema level, so MCP tools advertise the limits in their input schemas. The `check_*`
functions repeat the checks inside FleetService (which Zenoh and missions call directly) and add the ones that
need the world: poses within the world's bounds plus `POSE_MARGIN_M`, simple non-degenerate polygons. Every
failure is a FleetError (INVALID_ARGUMENT or OUT_OF_BOUNDS) naming the field. The limits table is in
docs/limits.md; keep both in step.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Annotated, Any, TypeVar

from pydantic import BaseModel, Field, TypeAdapter, ValidationError

from sim.errors import ErrorCode, FleetError

# ---- limits (docs/limits.md) ------------------------------------------------------------------------------
MAX_COORD_M = 1.0e4  # schema-level |x|, |y|, |z| bound; the world check is tighter
POSE_MARGIN_M = 10.0  # poses may lie this far outside the world's bounds (the geofence + margin)
MAX_ANGLE_RAD = 1.0e3  # yaw/roll/pitch magnitude (wrapped afterwards)
MAX_STEPS = 100_000  # physics steps per call (1000 s at 100 Hz)
MIN_SPEED, MAX_SPEED = 1.0e-3, 1.0e3  # real-time factor of the clock
MIN_SIZE_M, MAX_SIZE_M = 1.0e-4, 1.0e3  # model geometry extents
MAX_POLYGON_VERTICES = 200
MIN_POLYGON_AREA_M2 = 1.0e-4
MAX_TASKS = 200  # tasks per assign_tasks call, and in the unassigned queue
MAX_WAYPOINTS = 500
MIN_TOOL_WIDTH_M = 0.05
MAX_COVERAGE_LANES = 20_000  # coverage: swept length / tool width, bounded so planning stays in seconds
MIN_MAP_RESOLUTION_M, MAX_MAP_CELLS = 0.01, 16_000_000
MAX_VELOCITY = 1.0e3  # m/s or rad/s in velocity/force vectors before clamping
MAX_FORCE = 1.0e6  # N, N·m

Finite = Annotated[float, Field(allow_inf_nan=False)]
Coord = Annotated[float, Field(ge=-MAX_COORD_M, le=MAX_COORD_M, allow_inf_nan=False)]
Yaw = Annotated[float, Field(ge=-MAX_ANGLE_RAD, le=MAX_ANGLE_RAD, allow_inf_nan=False)]
Steps = Annotated[int, Field(ge=1, le=MAX_STEPS)]
Speed = Annotated[float, Field(ge=MIN_SPEED, le=MAX_SPEED, allow_inf_nan=False)]
Size = Annotated[float, Field(ge=MIN_SIZE_M, le=MAX_SIZE_M, allow_inf_nan=False)]
Velocity = Annotated[float, Field(ge=-MAX_VELOCITY, le=MAX_VELOCITY, allow_inf_nan=False)]
Force = Annotated[float, Field(ge=-MAX_FORCE, le=MAX_FORCE, allow_inf_nan=False)]
XY = tuple[Coord, Coord]
Polygon = Annotated[list[XY], Field(min_length=3, max_length=MAX_POLYGON_VERTICES)]
Vec3 = tuple[Finite, Finite, Finite]
VelocityVec = tuple[Velocity, Velocity, Velocity]
ForceVec = tuple[Force, Force, Force]

Bounds = tuple[float, float, float, float]
M = TypeVar("M", bound=BaseModel)


def bad(field: str, message: str, hint: str = "", code: ErrorCode = ErrorCode.INVALID_ARGUMENT) -> FleetError:
    return FleetError(code, f"{field}: {message}", hint or "see docs/limits.md for the accepted ranges")


def finite(field: str, v: Any, limit: float = MAX_COORD_M) -> float:
    """A real number with |v| ≤ limit (bools are not numbers here)."""
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise bad(field, f"expected a number, got {type(v).__name__}")
    f = float(v)
    if not math.isfinite(f):
        raise bad(field, f"must be finite, got {v!r}")
    if abs(f) > limit:
        raise bad(field, f"magnitude must be ≤ {limit:g}, got {f:g}")
    return f


def in_range(field: str, v: Any, lo: float, hi: float) -> float:
    f = finite(field, v, math.inf)
    if not lo <= f <= hi:
        raise bad(field, f"must be in [{lo:g}, {hi:g}], got {f:g}")
    return f


def count(field: str, n: Any, hi: int, lo: int = 0) -> int:
    if isinstance(n, bool) or not isinstance(n, int):
        raise bad(field, f"expected an integer, got {type(n).__name__}")
    if not lo <= n <= hi:
        raise bad(field, f"must be in [{lo}, {hi}], got {n}")
    return n


def steps(n: Any) -> int:
    return count("steps", n, MAX_STEPS, 0)


def speed(s: Any) -> float:
    return in_range("speed", s, MIN_SPEED, MAX_SPEED)


def grown(bounds: Bounds, margin: float = POSE_MARGIN_M) -> Bounds:
    return (bounds[0] - margin, bounds[1] - margin, bounds[2] + margin, bounds[3] + margin)


def xy(field: str, x: Any, y: Any, bounds: Bounds) -> tuple[float, float]:
    """A point inside the world's bounds grown by POSE_MARGIN_M."""
    fx, fy = finite(f"{field}.x", x), finite(f"{field}.y", y)
    xmin, ymin, xmax, ymax = grown(bounds)
    if not (xmin <= fx <= xmax and ymin <= fy <= ymax):
        raise bad(field, f"({fx:g}, {fy:g}) is outside the world bounds + {POSE_MARGIN_M:g} m margin "
                  f"[{xmin:.1f}, {xmax:.1f}] × [{ymin:.1f}, {ymax:.1f}]", "pick a point inside the world "
                  "(get_world_properties lists its bounds)", ErrorCode.OUT_OF_BOUNDS)
    return fx, fy


def pose(field: str, p: Any, bounds: Bounds) -> None:
    """A Pose2D/Pose3D-like object or {x, y, yaw} mapping: finite, inside the bounds, bounded angles."""
    get = p.get if isinstance(p, Mapping) else (lambda k, d=None: getattr(p, k, d))
    xy(field, get("x", 0.0), get("y", 0.0), bounds)
    for k in ("z",):
        if get(k) is not None:
            finite(f"{field}.{k}", get(k))
    for k in ("yaw", "roll", "pitch"):
        if get(k) is not None:
            finite(f"{field}.{k}", get(k), MAX_ANGLE_RAD)


def polygon(field: str, pts: Any, bounds: Bounds | None = None) -> list[tuple[float, float]]:
    """3..MAX_POLYGON_VERTICES finite vertices (inside the bounds when given), a simple polygon with area."""
    from shapely.geometry import Polygon as ShapelyPolygon

    if not isinstance(pts, Sequence) or isinstance(pts, str):
        raise bad(field, "expected a list of [x, y] vertices")
    count(f"{field} vertex count", len(pts), MAX_POLYGON_VERTICES, 3)
    out: list[tuple[float, float]] = []
    for i, v in enumerate(pts):
        if not isinstance(v, Sequence) or isinstance(v, str) or len(v) != 2:
            raise bad(f"{field}[{i}]", f"expected [x, y], got {v!r:.40}")
        out.append(xy(f"{field}[{i}]", v[0], v[1], bounds) if bounds else
                   (finite(f"{field}[{i}].x", v[0]), finite(f"{field}[{i}].y", v[1])))
    shape = ShapelyPolygon(out)
    if shape.area < MIN_POLYGON_AREA_M2:
        raise bad(field, f"area {shape.area:.2g} m² is below {MIN_POLYGON_AREA_M2:g} m² (degenerate polygon)")
    if not shape.is_valid:
        raise bad(field, "the polygon intersects itself", "list the vertices in order around the outline")
    return out


def coverage(outline: Sequence[tuple[float, float]], tool_width: Any, overlap: float = 0.0) -> None:
    """Bound the coverage plan: lanes = longest side / pass spacing, the spacing tool_width · (1 − overlap)."""
    from shapely.geometry import Polygon as ShapelyPolygon

    w = in_range("tool_width", tool_width, MIN_TOOL_WIDTH_M, 10.0)
    o = in_range("overlap", overlap, 0.0, 0.9)
    shape = ShapelyPolygon(outline)
    x0, y0, x1, y1 = shape.bounds
    lanes = max(x1 - x0, y1 - y0) / (w * (1.0 - o))
    if lanes > MAX_COVERAGE_LANES:
        raise bad("polygon", f"{lanes:.0f} coverage lanes at tool_width {w:g} m, overlap {o:g} (limit "
                  f"{MAX_COVERAGE_LANES})", "cover a smaller area, use a wider tool or less overlap")


_POINT_KEYS = ("goal", "pose", "target", "start")
_POLY_KEYS = ("polygon", "outline", "area")


def params(field: str, value: Any, bounds: Bounds, depth: int = 0) -> None:
    """Walk task/command parameters: every number finite and bounded, every point-like value (`goal`, a
    waypoint, {x, y}) inside the world, every `polygon`/`holes` a valid polygon."""
    if depth > 8:
        raise bad(field, "nested too deeply")
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return
    if isinstance(value, int | float):
        finite(field, value, 1.0e9)
        return
    if hasattr(value, "x") and hasattr(value, "y") and not isinstance(value, Mapping):
        pose(field, value, bounds)
        return
    if isinstance(value, Mapping):
        if "x" in value and "y" in value:
            pose(field, value, bounds)
        for k, v in value.items():
            key = str(k)
            if key in _POLY_KEYS and v is not None:
                polygon(f"{field}.{key}", v, bounds)
            elif key == "holes" and isinstance(v, Sequence):
                for i, h in enumerate(v):
                    polygon(f"{field}.holes[{i}]", h, bounds)
            else:
                params(f"{field}.{key}" if field else key, v, bounds, depth + 1)
        return
    if isinstance(value, Iterable):
        items = list(value)
        count(f"{field} length", len(items), 100_000)
        for i, v in enumerate(items):
            params(f"{field}[{i}]", v, bounds, depth + 1)


def model(kind: type[M], data: Any, where: str) -> M:
    """Validate `data` as `kind`; a failure is one readable INVALID_ARGUMENT line, never a pydantic dump."""
    try:
        return kind.model_validate(data)
    except ValidationError as exc:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{where}: {summarize(exc)}",
                         f"fields of {kind.__name__}: {', '.join(kind.model_fields)}") from None


def value(kind: Any, data: Any, where: str) -> Any:
    try:
        return TypeAdapter(kind).validate_python(data)
    except ValidationError as exc:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{where}: {summarize(exc)}") from None


def summarize(exc: ValidationError, limit: int = 3) -> str:
    """'field.sub: message (got X)' for the first few errors: what a person needs, without the dump."""
    parts = []
    for err in exc.errors()[:limit]:
        loc = ".".join(str(p) for p in err["loc"]) or "value"
        got = "" if err["type"] == "missing" else f" (got {repr(err.get('input'))[:40]})"
        parts.append(f"{loc}: {err['msg']}{got}")
    more = exc.error_count() - limit
    return "; ".join(parts) + (f"; and {more} more" if more > 0 else "")


def geometry(field: str, g: Any) -> None:
    """A collision/visual shape: every extent finite and in [MIN_SIZE_M, MAX_SIZE_M] (plane normals aside)."""
    kind = getattr(g, "kind", "?")
    sizes: list[float] = []
    if kind == "box":
        sizes = list(g.size)
    elif kind == "cylinder":
        sizes = [g.radius, g.length]
    elif kind == "sphere":
        sizes = [g.radius]
    elif kind == "plane":
        sizes = list(g.size)
    elif kind == "mesh":
        for i, s in enumerate(g.scale):
            finite(f"{field}.scale[{i}]", s, MAX_SIZE_M)
        return
    for i, s in enumerate(sizes):
        in_range(f"{field} ({kind}) size[{i}]", s, MIN_SIZE_M, MAX_SIZE_M)


def models(descs: Sequence[Any], bounds: Bounds) -> None:
    """Parsed SDF models about to be spawned: bounded shapes, every collision inside the world (+ margin)."""
    for m in descs:
        pose(f"model {m.name} pose", m.pose, bounds)
        for link, c, wp in m.world_collisions():
            where = f"model {m.name} link {link.name} collision {c.name}"
            geometry(where, c.geometry)
            if c.geometry.kind != "plane":
                xy(where, wp.x, wp.y, bounds)
        for link in m.links:
            for v in link.visuals:
                geometry(f"model {m.name} link {link.name} visual", v.geometry)


def map_resolution(config: Mapping[str, Any] | None, field: str = "mapping.resolution") -> None:
    """A SLAM/mapping config's grid resolution: at least MIN_MAP_RESOLUTION_M (a 1e-9 m grid never ends)."""
    section = (config or {}).get("mapping") if isinstance(config, Mapping) else None
    res = section.get("resolution") if isinstance(section, Mapping) else None
    if res is not None:
        in_range(field, res, MIN_MAP_RESOLUTION_M, 1.0)
