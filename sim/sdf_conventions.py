"""fleetnav's naming conventions inside SDF worlds (documented in docs/worlds.md).

- Spawn points: a world-level `<frame>` (SDF 1.7+) or a model without any collision whose name starts
  with `spawn` (any case). It becomes a `SpawnPoint`, never an obstacle or a model.
- Goal markers: models named `goal*` (e.g. `goal_marker`) with visuals only, so rays and robots pass through.
- Docking stations: models named `dock_*` with visuals only.
"""

from __future__ import annotations

from sim.errors import ErrorCode, FleetError
from sim.types import ModelDescription, Pose2D, WorldDescription

SPAWN_PREFIX = "spawn"
GOAL_PREFIX = "goal"
DOCK_PREFIX = "dock_"


def is_spawn_name(name: str) -> bool:
    return name.lower().startswith(SPAWN_PREFIX)


def is_marker(model: ModelDescription) -> bool:
    """A model with no collision at all (goal markers, docks): drawn, but no obstacle."""
    return not any(link.collisions for link in model.links)


def markers(world: WorldDescription, prefix: str) -> dict[str, Pose2D]:
    """Planar poses of the collision-free models whose name starts with `prefix`, by name."""
    return {m.name: m.pose.to_2d() for m in world.models if m.name.startswith(prefix) and is_marker(m)}


def goal_pose(world: WorldDescription) -> Pose2D:
    """The pose of the world's goal marker (the first `goal*` marker model)."""
    found = markers(world, GOAL_PREFIX)
    if not found:
        raise FleetError(ErrorCode.NOT_FOUND, f"world '{world.name}' has no goal marker",
                         f"add a collision-free model named '{GOAL_PREFIX}_marker'")
    return next(iter(found.values()))


def dock_poses(world: WorldDescription) -> dict[str, Pose2D]:
    return markers(world, DOCK_PREFIX)


def spawn_pose(world: WorldDescription, name: str | None = None) -> Pose2D:
    """A spawn point's pose: the named one, or the first when `name` is None."""
    if not world.spawn_points:
        raise FleetError(ErrorCode.NOT_FOUND, f"world '{world.name}' has no spawn point",
                         f"add a <frame name=\"{SPAWN_PREFIX}_...\"> to the world")
    if name is None:
        return world.spawn_points[0].pose
    for sp in world.spawn_points:
        if sp.name == name:
            return sp.pose
    known = ", ".join(sp.name for sp in world.spawn_points)
    raise FleetError(ErrorCode.NOT_FOUND, f"no spawn point '{name}' in world '{world.name}'",
                     f"spawn points: {known}")
