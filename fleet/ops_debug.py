"""FleetService operations for debugging: markers in the live view and recordings, model highlights, the
robot network drawn as markers, and the map image itself."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from fleet.core import ServiceCore
from fleet.map_image import map_png
from fleet.markers import DebugMarker, MarkerStore
from sim.errors import ErrorCode, FleetError, unknown_name
from sim.types import Pose2D

if TYPE_CHECKING:
    from fleet.service import FleetService

NETWORK_VIEWS = ("comms", "formation", "collision_zones", "tasks")


class DebugOps(ServiceCore):
    """Mixed into FleetService."""

    def _init_debug_ops(self) -> None:
        self.markers = MarkerStore()

    def add_marker(self, kind: str, points: Sequence[Sequence[float]], *, colour: str | Sequence[int] = "red",
                   size: float = 0.05, text: str = "", ns: str = "default",
                   lifetime_s: float | None = None) -> dict[str, Any]:
        """Add a marker (see fleet.markers.DebugMarker); it is published as a `debug_marker` event."""

        def do() -> dict[str, Any]:
            m = self.markers.add(kind, points, now=self.world.time, colour=colour, size=size, text=text, ns=ns,
                                 lifetime_s=lifetime_s)
            self.events.publish(self.world.time, "debug_marker", (), f"{m.kind} {m.id}", action="add",
                                marker=m.to_dict())
            return m.to_dict()

        return self.call(do)

    def clear_markers(self, marker_id: str | None = None, ns: str | None = None) -> list[str]:
        def do() -> list[str]:
            gone = self.markers.clear(marker_id, ns)
            if gone:
                self.events.publish(self.world.time, "debug_marker", (), f"cleared {len(gone)}", action="clear",
                                    ids=gone)
            return gone

        return self.call(do)

    def list_markers(self, ns: str | None = None) -> list[DebugMarker]:
        return self.call(lambda: self.markers.active(self.world.time, ns))

    def highlight_model(self, name: str, *, colour: str | Sequence[int] = "yellow", lifetime_s: float | None = None,
                        margin: float = 0.1) -> dict[str, Any]:
        """A box marker around a model's (or robot's) footprint, labelled with its name."""

        def do() -> dict[str, Any]:
            x0, y0, x1, y1 = self._extent(name)
            m = self.markers.add("box", [(x0 - margin, y0 - margin), (x1 + margin, y1 + margin)],
                                 now=self.world.time, colour=colour, size=0.05, text=name, ns="highlight",
                                 lifetime_s=lifetime_s)
            self.events.publish(self.world.time, "debug_marker", (), f"highlight {name}", action="add",
                                marker=m.to_dict())
            return m.to_dict()

        return self.call(do)

    def _extent(self, name: str) -> tuple[float, float, float, float]:
        if self.world.table.has(name):
            p, r = self.world.robot_pose(name), self.world.robot_spec(name).footprint_radius
            return (p.x - r, p.y - r, p.x + r, p.y + r)
        desc = self.world.description
        model = next((m for m in desc.models if m.name == name), None)
        if model is None:
            raise unknown_name("model", name, [m.name for m in desc.models] + self.world.robot_names(),
                               ErrorCode.UNKNOWN_MODEL)
        one = type(desc)(name=name, models=(model,))
        if not any(c.geometry.kind != "plane" for _, c, _ in model.world_collisions()):
            return (model.pose.x - 0.25, model.pose.y - 0.25, model.pose.x + 0.25, model.pose.y + 0.25)
        return one.bounds()

    def network_markers(self, view: str = "comms", comm_range: float = 5.0, robots: list[str] | None = None,
                        lifetime_s: float | None = 10.0) -> dict[str, Any]:
        """Draw the robot network as markers in namespace `network`, replacing the previous drawing:
        comms (an edge between robots within `comm_range`), formation (each robot to its group centre),
        collision_zones (a circle where two robots are within the near-miss distance), tasks (each robot
        to its current goal)."""
        if view not in NETWORK_VIEWS:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"unknown view '{view}'", f"views: {', '.join(NETWORK_VIEWS)}")
        if not (math.isfinite(comm_range) and comm_range > 0):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"comm_range must be > 0 m, got {comm_range}")

        def do() -> dict[str, Any]:
            names = self.world.robot_names() if robots is None else list(robots)
            for n in names:
                self.registry.get(n)
            self.markers.clear(ns="network")
            xy = {n: (p.x, p.y) for n, p in ((n, self.world.robot_pose(n)) for n in names)}
            segments = self._network(view, names, xy, comm_range)
            now = self.world.time
            kind = "circle" if view == "collision_zones" else "line"
            colour = {"comms": "cyan", "formation": "purple", "collision_zones": "red", "tasks": "green"}[view]
            made = [self.markers.add(kind, pts, now=now, colour=colour, size=size, ns="network", text=text,
                                     lifetime_s=lifetime_s) for pts, size, text in segments]
            self.events.publish(now, "debug_marker", (), f"network {view}: {len(made)} markers", action="network",
                                view=view, markers=[m.to_dict() for m in made])
            return {"view": view, "robots": len(names), "markers": len(made),
                    "edges": [{"points": [list(p) for p in pts], "label": text} for pts, _, text in segments[:200]]}

        return self.call(do)

    def _network(self, view: str, names: list[str], xy: dict[str, tuple[float, float]], comm_range: float
                 ) -> list[tuple[list[tuple[float, float]], float, str]]:
        out: list[tuple[list[tuple[float, float]], float, str]] = []
        if view in ("comms", "collision_zones"):
            limit = comm_range if view == "comms" else self.config.near_miss_distance + 2 * max(
                (self.world.robot_spec(n).footprint_radius for n in names), default=0.0)
            for i, a in enumerate(names):
                for b in names[i + 1:]:
                    d = math.dist(xy[a], xy[b])
                    if d <= limit:
                        if view == "comms":
                            out.append(([xy[a], xy[b]], 0.03, ""))
                        else:
                            mid = ((xy[a][0] + xy[b][0]) / 2, (xy[a][1] + xy[b][1]) / 2)
                            out.append(([mid], max(d / 2, 0.1), f"{a}-{b} {d:.2f} m"))
        elif view == "formation":
            if names:
                c = tuple(np.mean([xy[n] for n in names], axis=0).tolist())
                out = [([xy[n], (c[0], c[1])], 0.03, "") for n in names]
        else:  # tasks: each robot to the goal of its active task, if it has one
            for n in names:
                task = self.tasks.active.get(n)
                goal = task.params.get("goal") if task is not None else None
                if isinstance(goal, Pose2D):
                    out.append(([xy[n], (goal.x, goal.y)], 0.03, task.id if task else ""))
                elif isinstance(goal, dict) and {"x", "y"} <= set(goal):
                    out.append(([xy[n], (float(goal["x"]), float(goal["y"]))], 0.03, task.id if task else ""))
        return out

    def map_image(self, robot: str | None = None, *, show_robots: bool = True, show_markers: bool = True,
                  max_px: int = 800) -> tuple[bytes, dict[str, Any]]:
        """The static occupancy map (robot=None) or that robot's costmap (inflation, keep-outs, what its lidar
        sees) as a PNG, with robots, their goals and the markers drawn on; plus pixel ↔ map metadata."""
        if not 64 <= max_px <= 4096:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"max_px must be in [64, 4096], got {max_px}")
        svc = cast("FleetService", self)

        def do() -> tuple[bytes, dict[str, Any]]:
            if robot is not None:
                self.registry.get(robot)
            source = svc.prior_map() if robot is None else svc.costmap_for(robot)
            names = self.world.robot_names()
            marks = [(n, self.world.robot_pose(n)) for n in names] if show_robots else []
            goals = [g for g in (_goal_of(t.params) for t in self.tasks.active.values()) if g is not None]
            radius = self.world.robot_spec(names[0]).footprint_radius if names else None
            png, meta = map_png(source, robots=marks, goals=goals if show_robots else [],
                                markers=self.markers.active(self.world.time) if show_markers else [],
                                robot_radius=radius, max_px=max_px)
            meta.update({"layer": "static" if robot is None else f"costmap of {robot}", "robots": len(marks),
                         "markers": len(self.markers.markers) if show_markers else 0,
                         "cell_resolution": source.resolution})
            return png, meta

        return self.call(do)


def _goal_of(params: dict[str, Any]) -> Pose2D | None:
    g = params.get("goal")
    if isinstance(g, Pose2D):
        return g
    if isinstance(g, dict) and {"x", "y"} <= set(g):
        return Pose2D(float(g["x"]), float(g["y"]), float(g.get("yaw", 0.0)))
    return None
