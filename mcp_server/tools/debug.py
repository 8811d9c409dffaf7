"""Debug tools: markers drawn into the live view (the map image) and recordings, model highlights, and the
fleet's event log."""

from __future__ import annotations

from typing import Any, Literal

from mcp.server.mcpserver import Context
from pydantic import Field

from mcp_server.app import app_of, run
from mcp_server.registry import ToolRegistrar
from mcp_server.shaping import Answer

MarkerKind = Literal["point", "line", "arrow", "path", "polygon", "box", "circle", "text"]
Colour = Literal["red", "green", "blue", "yellow", "orange", "purple", "cyan", "magenta", "black", "white", "grey"] \
    | tuple[int, int, int]


class Marker(Answer):
    marker: dict[str, Any]


class Markers(Answer):
    markers: list[dict[str, Any]]
    count: int


class Cleared(Answer):
    cleared: list[str]


class Events(Answer):
    events: list[dict[str, Any]]
    last_seq: int = Field(description="pass as since_seq next time to get only newer events")


def register(tool: ToolRegistrar) -> None:
    @tool(read_only=False, title="Add a debug marker")
    async def add_debug_marker(ctx: Context, kind: MarkerKind,
                               points: list[tuple[float, float]] = Field(min_length=1, max_length=5000,
                                                                         description="map-frame [x, y] points"),
                               colour: Colour = "red", size: float = Field(0.05, gt=0, le=100, description="line "
                                                                           "width or radius, m"),
                               text: str = Field("", max_length=200), ns: str = Field("default", max_length=64),
                               lifetime_s: float | None = Field(None, gt=0, description="sim seconds; omitted: "
                                                                "until cleared")) -> Marker:
        """Draw a point, line, arrow, path (trajectory), polygon, box (two corners), circle (centre, size =
        radius) or text into the live view (get_occupancy_map) and recordings (a debug_marker event)."""
        svc = app_of(ctx).service
        m = await run(ctx, svc.add_marker, kind, points, colour=colour, size=size, text=text, ns=ns,
                      lifetime_s=lifetime_s)
        return Marker(sim_time=svc.sim_time, marker=m)

    @tool(read_only=False, destructive=True, idempotent=True, title="Clear debug markers")
    async def clear_debug_markers(ctx: Context, marker_id: str | None = Field(None, description="one marker; "
                                  "omitted: all (of `ns`)"), ns: str | None = None) -> Cleared:
        """Remove one marker, a namespace's markers, or all of them."""
        svc = app_of(ctx).service
        return Cleared(sim_time=svc.sim_time, cleared=await run(ctx, svc.clear_markers, marker_id, ns))

    @tool(read_only=True, title="List debug markers")
    async def list_debug_markers(ctx: Context, ns: str | None = None,
                                 limit: int = Field(100, ge=1, le=2000)) -> Markers:
        """Active (unexpired) markers, optionally of one namespace."""
        svc = app_of(ctx).service
        ms = await run(ctx, svc.list_markers, ns)
        return Markers(sim_time=svc.sim_time, count=len(ms), markers=[m.to_dict() for m in ms[-limit:]])

    @tool(read_only=False, title="Highlight a model")
    async def highlight_model(ctx: Context, name: str, colour: Colour = "yellow",
                              lifetime_s: float | None = Field(None, gt=0)) -> Marker:
        """Outline a model or robot with a labelled box marker."""
        svc = app_of(ctx).service
        m = await run(ctx, svc.highlight_model, name, colour=colour, lifetime_s=lifetime_s)
        return Marker(sim_time=svc.sim_time, marker=m)

    @tool(read_only=True, title="Recent events")
    async def recent_events(ctx: Context, since_seq: int = Field(0, ge=0), kinds: list[str] | None = None,
                            robot: str | None = None, limit: int = Field(50, ge=1, le=1000)) -> Events:
        """What happened, in order, stamped with sim time: tasks started/finished/failed, collisions, near
        misses, e-stops, deadlocks, markers... Poll with since_seq for only what is new."""
        svc = app_of(ctx).service
        evs = svc.events.since(since_seq, kinds, limit=100_000)
        if robot is not None:
            evs = [e for e in evs if robot in e.robots]
        return Events(sim_time=svc.sim_time, events=[e.to_dict() for e in evs[-limit:]],
                      last_seq=svc.events.last_seq)
