"""The challenge file (`configs/challenges/*.yaml`): a world, a start, a goal, the rules and how many runs.

A challenge names either a world (`world:` a name in configs/worlds or an SDF path relative to the file) or
a generated cluttered arena (`arena: {seed, difficulty, size}`, rebuilt deterministically by
sim.worldgen.cluttered_arena). Start and goal are `{x, y, yaw}` or the name of a spawn point or a marker
model of the world (`spawn_start`, `goal_marker`). `resolve` turns names into poses and writes a generated
arena to an SDF file, so the rest of grading only sees a world file and two poses.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from pydantic import Field, PrivateAttr, model_validator

from fleet.paths import CONFIGS, ROBOT_SUFFIXES, robot_file, world_file
from sim.config import StrictModel, load_yaml
from sim.errors import ErrorCode, FleetError
from sim.sdf_parser import parse_sdf
from sim.sdf_writer import save_sdf
from sim.types import Pose2D, WorldDescription
from sim.worldgen import cluttered_arena

CHALLENGES = CONFIGS / "challenges"
NAME = r"^[A-Za-z][A-Za-z0-9_\-]*$"


class PoseXY(StrictModel):
    x: float = Field(allow_inf_nan=False)
    y: float = Field(allow_inf_nan=False)
    yaw: float = Field(0.0, allow_inf_nan=False)


class ArenaSpec(StrictModel):
    """A generated cluttered arena (walls, random boxes and cylinders, a free corridor start → goal)."""

    seed: int = Field(ge=0)
    difficulty: int = Field(ge=1, le=5, description="obstacle density, 1 (sparse) .. 5 (dense)")
    size: float = Field(10.0, ge=4.0, le=60.0, description="side of the square arena, m")


class AgentSection(StrictModel):
    """Wall-clock limits for a contestant's process: how a crash or a hang becomes a graded failure."""

    startup_timeout_s: float = Field(30.0, gt=0, le=600, description="to connect and join lock-step")
    tick_timeout_s: float = Field(2.0, gt=0, le=120, description="per lock-step tick before it counts as hung")
    wall_limit_s: float = Field(900.0, gt=0, le=36_000, description="whole run, wall clock")


class Challenge(StrictModel):
    name: str = Field(pattern=NAME)
    description: str = ""
    world: str | None = Field(None, description="a world in configs/worlds, or an SDF path (relative to this file)")
    arena: ArenaSpec | None = Field(None, description="a generated arena instead of `world`")
    start: PoseXY | str = Field(description="{x, y, yaw} or the name of a spawn point / marker model")
    goal: PoseXY | str = Field(description="{x, y} or the name of a marker model / spawn point")
    success_radius: float = Field(0.5, gt=0, le=5, description="the goal counts as reached within this, m")
    time_limit: float = Field(gt=0, le=3600, description="sim seconds per run")
    collision: Literal["end", "count"] = Field(
        "end", description="end: the first contact ends the run as a failure (BARN); count: keep going, report")
    robot: str = Field("diffbot", description="a shipped robot model name, or a .yaml/.urdf/.urdf.xacro file "
                       "(relative to this file)")
    fidelity: Literal["kinematic", "dynamic"] = "kinematic"
    physics_hz: float = Field(100.0, ge=10, le=2000)
    control_hz: float = Field(10.0, ge=1, le=200)
    runs: int = Field(1, ge=1, le=100, description="runs per contestant; run k uses seed + k")
    seed: int = Field(0, ge=0)
    safety_distance: float = Field(0.3, ge=0, description="clearance below which time counts as in danger, m")
    optimal_planner: str = Field("guided_theta_star", description="planner for the optimal path (T_opt)")
    # Default `sensors`: a graded robot must not read the world file. The builtins navigate on their lidar
    # and an agent is refused the world's occupancy map (fleet.ops_nav.withhold_prior_map).
    map_source: Literal["sensors", "prior", "both"] = Field(
        "sensors", description="what the contestant may know of the world: sensors (only its own lidar; the "
        "world's occupancy map is refused to an agent), prior (a builtin navigates on the world's obstacles, an "
        "agent may ask for the map: fleets in known warehouses), both (a builtin's prior map corrected by its lidar)")
    agent: AgentSection = Field(default_factory=AgentSection)
    _base_dir: Path = PrivateAttr(default_factory=Path.cwd)

    @model_validator(mode="after")
    def _checks(self) -> Challenge:
        if (self.world is None) == (self.arena is None):
            raise ValueError("give exactly one of world or arena")
        if self.control_hz > self.physics_hz:
            raise ValueError(f"control_hz {self.control_hz} exceeds physics_hz {self.physics_hz}")
        return self


@dataclass(frozen=True)
class ResolvedChallenge:
    """A challenge made concrete: the SDF file to load, its description, and the two poses."""

    challenge: Challenge
    world_path: Path
    description: WorldDescription
    start: Pose2D
    goal: Pose2D


def challenge_file(name_or_path: str | Path) -> Path:
    """'arena_course' → configs/challenges/arena_course.yaml; a path is returned as is."""
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml"):
        return p
    cand = CHALLENGES / f"{name_or_path}.yaml"
    if cand.is_file():
        return cand
    known = sorted(f.stem for f in CHALLENGES.glob("*.yaml"))
    raise FleetError(ErrorCode.NOT_FOUND, f"no challenge '{name_or_path}'",
                     f"known challenges: {', '.join(known) or '(none)'}; or give a path to a .yaml file")


def load_challenge(name_or_path: str | Path) -> Challenge:
    path = challenge_file(name_or_path)
    ch = load_yaml(path, Challenge)
    ch._base_dir = path.resolve().parent
    if Path(ch.robot).suffix in ROBOT_SUFFIXES:  # like `world:`, a robot file is relative to the challenge file
        ch.robot = str(robot_file(ch.robot, ch._base_dir))
    return ch


def resolve(ch: Challenge, work_dir: str | Path) -> ResolvedChallenge:
    """World file and poses. A generated arena is written to `work_dir/<name>.world` (kept with the report)."""
    if ch.arena is not None:
        desc = cluttered_arena(ch.arena.seed, ch.arena.difficulty, ch.arena.size)
        path = Path(work_dir) / f"{desc.name}.world"
        path.parent.mkdir(parents=True, exist_ok=True)
        save_sdf(desc, path, comment=f"generated for challenge {ch.name}: {ch.arena.model_dump()}")
    else:
        assert ch.world is not None
        rel = ch._base_dir / ch.world
        path = rel if rel.suffix in (".world", ".sdf") and rel.is_file() else world_file(ch.world)
        desc = parse_sdf(str(path))
    start, goal = place(ch.start, desc, "start"), place(ch.goal, desc, "goal")
    if start.distance_to(goal) <= ch.success_radius:
        raise FleetError(ErrorCode.INVALID_CONFIG, f"challenge {ch.name}: the start is already within "
                         f"success_radius {ch.success_radius} m of the goal", "move the start or the goal")
    return ResolvedChallenge(ch, path, desc, start, goal)


def place(where: PoseXY | str, desc: WorldDescription, what: str) -> Pose2D:
    """A pose from `{x, y, yaw}`, or from a spawn point or model of the world by name."""
    if isinstance(where, PoseXY):
        return Pose2D(where.x, where.y, where.yaw)
    spawns = {s.name: s.pose for s in desc.spawn_points}
    if where in spawns:
        return spawns[where]
    models = {m.name: m.pose.to_2d() for m in desc.models}
    if where in models:
        return models[where]
    known = sorted(spawns) + sorted(n for n in models if n.startswith(("goal", "spawn", "start", "dock")))
    raise FleetError(ErrorCode.INVALID_CONFIG, f"{what} '{where}' is neither a spawn point nor a model of world "
                     f"'{desc.name}'", f"known: {', '.join(known) or '(none)'}; or give {{x, y, yaw}}")
