"""Where SDF URIs point on disk: `model://` lookups through a model path, relative and file:// URIs,
Fuel URLs served from the local Fuel cache, and `model.config` files (which SDF file a model dir uses).
"""

from __future__ import annotations

import os
from pathlib import Path
from urllib.parse import unquote, urlparse

from sim.errors import ErrorCode, FleetError
from sim.read_policy import allowed
from sim.resources import shipped
from sim.sdf_xml import Node, parse_xml

DEFAULT_MODEL_DIR = shipped("models")
MODEL_PATH_ENV = ("GAZEBO_MODEL_PATH", "GZ_SIM_RESOURCE_PATH", "IGN_GAZEBO_RESOURCE_PATH")
FUEL_CACHES = (Path.home() / ".gz" / "fuel", Path.home() / ".ignition" / "fuel")


def model_search_path(extra: list[str] | None = None) -> list[Path]:
    """The model path in lookup order: arguments, then the Gazebo env vars, then configs/models."""
    dirs = [Path(d) for d in (extra or [])]
    for var in MODEL_PATH_ENV:
        dirs += [Path(d) for d in os.environ.get(var, "").split(os.pathsep) if d]
    dirs.append(DEFAULT_MODEL_DIR)
    out: list[Path] = []
    for d in dirs:
        if d not in out:
            out.append(d)
    return out


def _fuel_cache_dir(url: str) -> Path | None:
    """https://fuel.gazebosim.org/1.0/<owner>/models/<name>[/<version>] in the local Fuel cache, if cached."""
    u = urlparse(url)
    parts = [unquote(p) for p in u.path.split("/") if p]
    if "models" not in parts or parts.index("models") < 1 or parts.index("models") + 1 >= len(parts):
        return None
    i = parts.index("models")
    owner, name = parts[i - 1].lower(), parts[i + 1].lower()
    for cache in FUEL_CACHES:
        d = cache / u.netloc / owner / "models" / name
        versions = sorted((v for v in d.glob("*") if v.is_dir() and v.name.isdigit()), key=lambda v: int(v.name))
        if versions:
            return versions[-1]
    return None


def find_model_dir(name: str, search: list[Path]) -> Path | None:
    for d in search:
        cand = d / name
        if (cand / "model.config").is_file() or (cand / "model.sdf").is_file():
            return cand
    return None


def resolve_uri(uri: str, base_dir: Path, search: list[Path]) -> Path | None:
    """The local path of a model:// / file:// / relative / absolute URI (None if it does not exist)."""
    if uri.startswith("model://"):
        name, _, rest = uri[len("model://"):].partition("/")
        model_dir = find_model_dir(name, search)
        if model_dir is None:
            return None
        p = model_dir / rest if rest else model_dir
    elif uri.startswith(("http://", "https://")):
        cached = _fuel_cache_dir(uri)
        if cached is None:
            return None
        rest = uri.split("/files/", 1)[1] if "/files/" in uri else ""
        p = cached / rest if rest else cached
    elif uri.startswith("file://"):
        p = Path(unquote(uri[len("file://"):]))
    else:
        p = Path(uri) if Path(uri).is_absolute() else base_dir / uri
    p = p.resolve()
    return p if p.exists() and allowed(p) else None  # refused by the read policy = missing


def model_sdf_file(model_dir: Path) -> Path:
    """The SDF file of a model dir: the newest `<sdf>` entry of model.config, else model.sdf."""
    cfg = model_dir / "model.config"
    if cfg.is_file():
        root = parse_xml(cfg.read_text(encoding="utf-8"), str(cfg))
        entries = [(n.attrib.get("version", "0"), n.text.strip()) for n in root.findall("sdf") if n.text.strip()]
        entries.sort(key=lambda e: tuple(int(x) for x in e[0].split(".") if x.isdigit()))
        if entries:
            return model_dir / entries[-1][1]
    return model_dir / "model.sdf"


def resolve_include(uri: str, node: Node, base_dir: Path, search: list[Path]) -> Path:
    """The SDF file an <include><uri> names; a missing model is an error naming the URI and search path."""
    p = resolve_uri(uri, base_dir, search)
    if p is not None and p.is_dir():
        p = model_sdf_file(p)
    if p is None or not p.is_file():
        where = ", ".join(str(d) for d in search)
        raise FleetError(ErrorCode.NOT_FOUND, f"{node.where()}: cannot find included model '{uri}'",
                         f"searched the model path: {where} (add a directory with --model-path, "
                         "GAZEBO_MODEL_PATH or GZ_SIM_RESOURCE_PATH)")
    return p


def read_text(path: Path, node: Node | None = None) -> str:
    try:
        return path.read_text(encoding="utf-8")
    except OSError as exc:
        where = f"{node.where()}: " if node is not None else ""
        raise FleetError(ErrorCode.NOT_FOUND, f"{where}cannot read {path}: {exc.strerror}",
                         "check the path") from exc
