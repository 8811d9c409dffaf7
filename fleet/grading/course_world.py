"""`fleetnav check world`: grade an SDF world against the course's "Custom Gazebo World" requirements (15 pts)."""

from __future__ import annotations

from pathlib import Path

from fleet.grading.rubric import RubricReport
from sim.sdf_conventions import is_marker
from sim.sdf_parser import parse_sdf
from sim.types import Box, ModelDescription, WorldDescription

MIN_SIZE = 10.0  # m, each side
MIN_OBSTACLES = 5
MIN_LIGHTS = 2
BARRIER_MIN_LENGTH = 2.0  # m: a wall segment long enough to shape a maze
BARRIER_MAX_THICKNESS = 0.6  # m


def _kinds(model: ModelDescription) -> set[str]:
    return {c.geometry.kind for _, c, _ in model.world_collisions()}


def _is_barrier(model: ModelDescription) -> bool:
    for _, c, _ in model.world_collisions():
        if isinstance(c.geometry, Box):
            sx, sy = sorted(c.geometry.size[:2], reverse=True)
            if sx >= BARRIER_MIN_LENGTH and sy <= BARRIER_MAX_THICKNESS:
                return True
    return False


def check_world(path: str | Path) -> RubricReport:
    desc = parse_sdf(str(path))
    return grade_world(desc, str(path))


def grade_world(desc: WorldDescription, source: str) -> RubricReport:
    rep = RubricReport("Custom Gazebo World (worlds/robot_arena.world)", source)
    solid = [m for m in desc.models if not is_marker(m) and _kinds(m) - {"plane"}]
    ground = [m for m in desc.models if "plane" in _kinds(m)]
    barriers = [m for m in solid if _is_barrier(m)]
    obstacles = [m for m in solid if m not in barriers]
    shapes = set().union(*(_kinds(m) for m in obstacles)) if obstacles else set()
    variety = {k for k in shapes if k in ("box", "cylinder", "sphere")}
    xmin, ymin, xmax, ymax = desc.bounds()
    size = (xmax - xmin, ymax - ymin)
    textured = bool(ground) and desc.ground_material is not None

    rep.add("sdf_format", "world is valid SDF", 1, True, f"SDF {desc.sdf_version}, parsed", "parses as SDF")
    rep.add("ground_textured", "ground plane with a textured surface", 2, textured,
            f"{len(ground)} ground plane(s), material {desc.ground_material!r}", "a plane with a material/texture")
    rep.add("obstacle_count", f"at least {MIN_OBSTACLES} obstacles", 3, len(obstacles) >= MIN_OBSTACLES,
            f"{len(obstacles)} obstacles", f"≥ {MIN_OBSTACLES}")
    rep.add("shape_variety", "obstacles of different shapes (boxes, cylinders, spheres)", 2,
            variety == {"box", "cylinder", "sphere"}, ", ".join(sorted(variety)) or "none",
            "box, cylinder and sphere")
    rep.add("barriers", "physical barriers forming a maze or navigation challenge", 3, len(barriers) >= 2,
            f"{len(barriers)} wall segments ≥ {BARRIER_MIN_LENGTH} m long", "≥ 2")
    rep.add("lights", f"at least {MIN_LIGHTS} light sources", 2, len(desc.lights) >= MIN_LIGHTS,
            f"{len(desc.lights)} lights", f"≥ {MIN_LIGHTS}")
    rep.add("size", f"world at least {MIN_SIZE:g} m × {MIN_SIZE:g} m", 1,
            min(size) >= MIN_SIZE - 1e-6, f"{size[0]:.2f} m × {size[1]:.2f} m", f"≥ {MIN_SIZE:g} × {MIN_SIZE:g}")
    rep.add("spawn_point", "a spawn point for the robot", 1, bool(desc.spawn_points),
            ", ".join(s.name for s in desc.spawn_points) or "none", "a frame/model named spawn*")
    if desc.unsupported:
        rep.notes.append(f"elements fleetnav does not simulate: {', '.join(desc.unsupported[:10])}")
    return rep
