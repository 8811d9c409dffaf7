"""Where shipped configs live, name → file resolution, and workspace confinement of file arguments."""

from __future__ import annotations

from pathlib import Path

from fleet.workspace import Workspace
from sim.errors import ErrorCode, FleetError

__all__ = ["CONFIGS", "ROOT", "Workspace", "robot_file", "world_file"]  # Workspace lives in fleet/workspace.py

ROOT = Path(__file__).resolve().parent.parent
CONFIGS = ROOT / "configs"


def world_file(name_or_path: str) -> Path:
    """'robot_arena' → configs/worlds/robot_arena.world; a path is returned as is (if it exists)."""
    p = Path(name_or_path)
    if p.suffix in (".world", ".sdf") and p.is_file():
        return p
    for cand in (CONFIGS / "worlds" / f"{name_or_path}.world", CONFIGS / "worlds" / f"{name_or_path}.sdf"):
        if cand.is_file():
            return cand
    known = sorted(f.stem for f in (CONFIGS / "worlds").glob("*.world"))
    raise FleetError(ErrorCode.NOT_FOUND, f"no world '{name_or_path}'", f"known worlds: {', '.join(known)}; "
                     "or give a path to an SDF file")


def robot_file(name_or_path: str) -> Path:
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml") and p.is_file():
        return p
    cand = CONFIGS / "robots" / f"{name_or_path}.yaml"
    if cand.is_file():
        return cand
    known = sorted(f.stem for f in (CONFIGS / "robots").glob("*.yaml"))
    raise FleetError(ErrorCode.NOT_FOUND, f"no robot model '{name_or_path}'", f"known models: {', '.join(known)}")
