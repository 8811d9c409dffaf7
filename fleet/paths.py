"""Where shipped configs live, name → file resolution, and workspace confinement of file arguments."""

from __future__ import annotations

from pathlib import Path

from fleet.workspace import Workspace
from sim.errors import ErrorCode, FleetError
from sim.resource_path import package_search_path
from sim.resources import shipped_root
from sim.robot_load import is_robot_text, load_robot_model
from sim.urdf_robot import LoadedRobot

# Workspace lives in fleet/workspace.py
__all__ = ["CONFIGS", "ROOT", "Workspace", "robot_file", "robot_model", "world_file"]

ROOT = Path(__file__).resolve().parent.parent
CONFIGS = shipped_root()  # the shipped configs (sim.resources: found through importlib.resources)
ROBOT_SUFFIXES = (".yaml", ".yml", ".urdf", ".xacro")


def _relative(name_or_path: str, base: Path | None) -> Path | None:
    """An existing file `name_or_path` as given, or relative to `base` (the referencing file's folder)."""
    p = Path(name_or_path)
    if base is not None and not p.is_absolute() and (base / p).is_file():
        return (base / p).resolve()
    return p.resolve() if p.is_file() else None


def world_file(name_or_path: str, base: Path | None = None) -> Path:
    """'robot_arena' → the shipped worlds/robot_arena.world; a path is taken relative to `base` first."""
    p = Path(name_or_path)
    if p.suffix in (".world", ".sdf") and (found := _relative(name_or_path, base)) is not None:
        return found
    for cand in (CONFIGS / "worlds" / f"{name_or_path}.world", CONFIGS / "worlds" / f"{name_or_path}.sdf"):
        if cand.is_file():
            return cand
    known = sorted(f.stem for f in (CONFIGS / "worlds").glob("*.world"))
    raise FleetError(ErrorCode.NOT_FOUND, f"no world '{name_or_path}'", f"known worlds: {', '.join(known)}; "
                     "or give a path to an SDF file")


def robot_file(name_or_path: str, base: Path | None = None) -> Path:
    """'diffbot' → the shipped robots/diffbot.yaml (or .urdf/.urdf.xacro); a .yaml/.urdf/.xacro path is taken
    relative to `base` first."""
    p = Path(name_or_path)
    if p.suffix in ROBOT_SUFFIXES:
        found = _relative(name_or_path, base)
        if found is None:
            where = f" (relative to {base})" if base is not None and not p.is_absolute() else ""
            raise FleetError(ErrorCode.NOT_FOUND, f"robot model file '{name_or_path}' does not exist{where}",
                             "check the path; relative paths start from the file that names them")
        return found
    for suffix in (".yaml", ".urdf", ".urdf.xacro"):
        cand = CONFIGS / "robots" / f"{name_or_path}{suffix}"
        if cand.is_file():
            return cand
    known = sorted({f.name.split(".")[0] for f in (CONFIGS / "robots").iterdir() if f.suffix in ROBOT_SUFFIXES})
    raise FleetError(ErrorCode.NOT_FOUND, f"no robot model '{name_or_path}'",
                     f"known models: {', '.join(known)}; or give a .yaml, .urdf or .urdf.xacro file")


def robot_model(model: str, base: Path | None = None, package_path: list[str] | None = None) -> LoadedRobot:
    """A robot model by name, file (relative to `base` first) or URDF/xacro text, with its load warnings;
    `package_path` folders are searched for package:// and $(find) before the environment's."""
    search = package_search_path(list(package_path or []))
    return load_robot_model(model if is_robot_text(model) else robot_file(model, base), search)

