"""`fleetnav zenoh` in one command: which Zenoh config, which robots where (`NAME@spawn_point` or
`NAME@x,y,yaw`), parsed with errors that name the bad argument and list what is valid."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from fleet.paths import CONFIGS
from fleet.zenoh_api import check_name
from sim.errors import ErrorCode, FleetError
from sim.sdf_conventions import SPAWN_PREFIX, spawn_pose
from sim.types import Pose2D, WorldDescription


@dataclass(frozen=True)
class SpawnArg:
    name: str
    at: str | None  # a spawn point name, or None: the world's first spawn point
    pose: Pose2D | None  # explicit x,y,yaw


def zenoh_config_file(name_or_path: str | Path) -> Path:
    """A Zenoh config: a YAML file (relative to the current folder), or a shipped one by name ('local', 'lan',
    ...), so the command works from any folder."""
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml") and p.is_file():
        return p
    shipped = CONFIGS / "zenoh" / f"{p.stem if p.suffix in ('.yaml', '.yml') else name_or_path}.yaml"
    if shipped.is_file():
        return shipped
    known = sorted(f.stem for f in (CONFIGS / "zenoh").glob("*.yaml"))
    raise FleetError(ErrorCode.NOT_FOUND, f"no Zenoh config '{name_or_path}'",
                     f"give a YAML file, or one of the shipped configs: {', '.join(known)}")


def parse_spawn(arg: str) -> SpawnArg:
    """'r1' | 'r1@spawn_start' | 'r1@start' | 'r1@1.5,-2,0.3' (yaw in radians, optional)."""
    name, _, where = arg.partition("@")
    try:
        check_name("robot name", name)
    except FleetError as exc:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"--spawn {arg}: {exc.message}", exc.hint) from exc
    if not where:
        return SpawnArg(name, None, None)
    if where[0].isdigit() or where[0] in "-+.":
        parts = where.split(",")
        try:
            nums = [float(v) for v in parts]
        except ValueError:
            nums = []
        if len(nums) not in (2, 3) or not all(math.isfinite(v) for v in nums):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"--spawn {arg}: '{where}' is not x,y or x,y,yaw",
                             "e.g. --spawn r2@1.5,-2,0.3 (metres, radians) or --spawn r1@<spawn point>")
        return SpawnArg(name, None, Pose2D(nums[0], nums[1], nums[2] if len(nums) == 3 else 0.0))
    return SpawnArg(name, where, None)


def resolve_spawns(args: list[str], world: WorldDescription) -> list[tuple[str, Pose2D]]:
    """Each robot's pose in `world`; a repeated name is an error."""
    out: list[tuple[str, Pose2D]] = []
    for raw in args:
        s = parse_spawn(raw)
        if any(n == s.name for n, _ in out):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"--spawn {raw}: robot '{s.name}' is spawned twice",
                             "give each robot its own name")
        if s.pose is not None:
            out.append((s.name, s.pose))
            continue
        at = s.at
        names = {sp.name for sp in world.spawn_points}
        if at is not None and at not in names and f"{SPAWN_PREFIX}_{at}" in names:
            at = f"{SPAWN_PREFIX}_{at}"
        try:
            out.append((s.name, spawn_pose(world, at)))
        except FleetError as exc:
            raise FleetError(exc.code, f"--spawn {raw}: {exc.message}", exc.hint or "or give x,y,yaw") from exc
    return out
