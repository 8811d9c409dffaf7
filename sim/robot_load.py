"""One entry point for robot models: a robot YAML (sim.robot_spec), a URDF or a xacro (sim.urdf_robot), given as a
file or as text. Returns the spec and the warnings about what the description left out (empty for YAML)."""

from __future__ import annotations

from pathlib import Path

from sim.config import load_yaml
from sim.errors import ErrorCode, FleetError
from sim.robot_spec import RobotSpec
from sim.urdf_robot import LoadedRobot, load_urdf_robot

YAML_SUFFIXES = (".yaml", ".yml")
URDF_SUFFIXES = (".urdf", ".xacro")


def is_robot_text(model: str) -> bool:
    return model.lstrip().startswith("<")


def load_robot_model(model: str | Path, package_path: list[Path] | None = None) -> LoadedRobot:
    """`model`: a .yaml/.yml, .urdf, .urdf.xacro/.xacro file, or URDF/xacro text."""
    if isinstance(model, str) and is_robot_text(model):
        return load_urdf_robot(model, package_path)
    path = Path(model)
    if path.suffix in YAML_SUFFIXES:
        if not path.is_file():
            raise FleetError(ErrorCode.NOT_FOUND, f"cannot read robot model {path}: no such file", "check the path")
        return LoadedRobot(load_yaml(path, RobotSpec), (), str(path))
    if path.suffix in URDF_SUFFIXES:
        return load_urdf_robot(path, package_path)
    raise FleetError(ErrorCode.INVALID_ARGUMENT, f"robot model '{model}' is neither YAML nor URDF",
                     "give a .yaml, .urdf or .urdf.xacro file, or URDF text")
