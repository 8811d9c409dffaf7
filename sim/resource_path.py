"""Where a robot description's URIs point on disk: `package://pkg/...` through a package search path,
`model://name/...` through the SDF model path (sim.sdf_paths), `file://` and relative paths from the
referencing file.

Package search path, in lookup order: directories given by the caller (a config's `package_path:`), then
FLEETNAV_PACKAGE_PATH, ROS_PACKAGE_PATH (os.pathsep lists of folders holding packages, searched recursively
two levels deep as ROS 1 did), then AMENT_PREFIX_PATH prefixes (`<prefix>/share/<pkg>`, as ROS 2 installs
them). A package is a folder named `pkg`, normally holding a package.xml.
"""

from __future__ import annotations

import os
from pathlib import Path
from urllib.parse import unquote

from sim.errors import ErrorCode, FleetError
from sim.sdf_paths import find_model_dir, model_search_path

PACKAGE_PATH_ENV = ("FLEETNAV_PACKAGE_PATH", "ROS_PACKAGE_PATH")
HINT = ("add the folder that holds the package to FLEETNAV_PACKAGE_PATH (or ROS_PACKAGE_PATH / "
        "AMENT_PREFIX_PATH), or use a path relative to the file")


def package_search_path(extra: list[str | Path] | None = None) -> list[Path]:
    dirs = [Path(d) for d in (extra or [])]
    for var in PACKAGE_PATH_ENV:
        dirs += [Path(d) for d in os.environ.get(var, "").split(os.pathsep) if d]
    dirs += [Path(d) / "share" for d in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if d]
    out: list[Path] = []
    for d in dirs:
        if d not in out:
            out.append(d)
    return out


def find_package(name: str, search: list[Path]) -> Path | None:
    """The folder of package `name`: `<dir>/<name>` or one level further down (a workspace's src/)."""
    for d in search:
        for cand in (d / name, *(sub / name for sub in _subdirs(d))):
            if cand.is_dir() and ((cand / "package.xml").is_file() or cand.parent == d):
                return cand.resolve()
    return None


def _subdirs(d: Path) -> list[Path]:
    try:
        return sorted(p for p in d.iterdir() if p.is_dir())
    except OSError:
        return []


def resolve_resource(uri: str, base_dir: Path, package_path: list[Path] | None = None,
                     model_path: list[Path] | None = None, *, where: str = "") -> Path:
    """The existing file `uri` names; a FleetError naming the URI and the searched folders otherwise."""
    search = package_path if package_path is not None else package_search_path()
    if uri.startswith("package://"):
        name, _, rest = uri[len("package://"):].partition("/")
        pkg = find_package(name, search)
        if pkg is None:
            raise FleetError(ErrorCode.NOT_FOUND, f"{where}cannot find package '{name}' of '{uri}'",
                             f"searched: {', '.join(map(str, search)) or 'nothing'}; {HINT}")
        path = pkg / rest
    elif uri.startswith("model://"):
        models = model_path if model_path is not None else model_search_path()
        name, _, rest = uri[len("model://"):].partition("/")
        model_dir = find_model_dir(name, models)
        if model_dir is None:
            raise FleetError(ErrorCode.NOT_FOUND, f"{where}cannot find model '{name}' of '{uri}'",
                             f"searched the model path: {', '.join(map(str, models))}")
        path = model_dir / rest
    elif uri.startswith("file://"):
        path = Path(unquote(uri[len("file://"):]))
    else:
        path = Path(uri) if Path(uri).is_absolute() else base_dir / uri
    if not path.exists():
        raise FleetError(ErrorCode.NOT_FOUND, f"{where}'{uri}' points to {path}, which does not exist", HINT)
    return path.resolve()
