"""Workspace confinement: every file a front door names resolves inside the workspace or the shipped configs.

- Reads: a relative path is looked up in the workspace root, then in its outputs area; an absolute one must
  be inside the root or the shipped configs. Symlinks are resolved before the check. A path that is outside,
  missing or not a file gets the same NOT_FOUND answer, so the error is no existence oracle.
- Writes go only to the outputs area (`<root>/outputs`); a relative path is taken relative to it. A file the
  server did not create is never overwritten unless the caller permits it (`overwrite: true`).
- No default workspace at `/` or the home directory: without a configured root the server uses a dedicated
  folder (`$FLEETNAV_WORKSPACE`, else `$XDG_DATA_HOME/fleetnav/workspace`).
- Names (worlds, robot models) are plain identifiers looked up in the shipped configs; anything with a path
  separator is a path and goes through the rules above.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from sim.errors import ErrorCode, FleetError
from sim.resources import shipped_root

CONFIGS = shipped_root()  # sim.resources: the shipped configs, wherever fleetnav is installed
NAME_RE = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.\-]{0,127}$")
MANIFEST = ".fleetnav-written"  # in the outputs area: files this server wrote (it may overwrite them)


def default_root() -> Path:
    env = os.environ.get("FLEETNAV_WORKSPACE")
    if env:
        return Path(env)
    data = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return Path(data) / "fleetnav" / "workspace"


def _checked(path: str | Path) -> str:
    """A path argument as text: no NUL or other control characters, a sane length (else INVALID_ARGUMENT)."""
    text = str(path)
    if len(text) > 1024 or any(ord(c) < 32 or c == "\x7f" for c in text):
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"unusable path {text[:40]!r}",
                         "a path of printable characters, at most 1024 long")
    return text


def _inside(p: Path, root: Path) -> bool:
    return p == root or root in p.parents


class Workspace:
    """File arguments from front doors resolve inside `root` (shipped configs may be read too)."""

    def __init__(self, root: str | Path | None = None) -> None:
        raw = Path(root).expanduser() if root not in (None, "") else default_root()
        raw.mkdir(parents=True, exist_ok=True)
        self.root = raw.resolve()
        if self.root == Path(self.root.anchor) or self.root == Path.home().resolve():
            raise FleetError(ErrorCode.INVALID_CONFIG, f"refusing {self.root} as the workspace: it would expose "
                             "the whole filesystem or home directory", "give a dedicated directory (--workspace), "
                             "or omit it to use ~/.local/share/fleetnav/workspace")
        self.outputs = self.root / "outputs"
        self.shipped = CONFIGS.resolve()
        self._written: set[Path] | None = None
        self.trusted: list[Path] = []  # folders a trusted local config (a mission file) named: readable too

    def trust(self, folder: str | Path) -> None:
        """Let reads reach `folder` too: for files a trusted local config names (a mission's robot model and
        the meshes beside it), never for paths a front-door call supplies."""
        full = Path(folder).resolve()
        if full not in self.trusted:
            self.trusted.append(full)

    # ---- reads -------------------------------------------------------------------------------------------

    def readable(self, p: Path) -> bool:
        """Whether a resolved path lies inside the workspace or the shipped configs (the sim's read policy)."""
        full = p.resolve()
        return _inside(full, self.root) or _inside(full, self.shipped) or any(_inside(full, d) for d in self.trusted)

    def read(self, path: str | Path, what: str = "file", *, allow_dir: bool = False) -> Path:
        p = Path(_checked(path).removeprefix("file://"))
        cands = [p] if p.is_absolute() else [self.root / p, self.outputs / p]
        for c in cands:
            full = c.resolve()
            if self.readable(full) and (full.is_file() or (allow_dir and full.is_dir())):
                return full
        raise FleetError(ErrorCode.NOT_FOUND, f"no readable {what} '{path}' in the workspace or the shipped configs",
                         f"give a path relative to the workspace {self.root}")

    def resolve(self, path: str | Path, *, write: bool = False) -> Path:
        """Kept for callers of the old API: `write` → `write_path`, else `read`."""
        return self.write_path(path) if write else self.read(path, allow_dir=True)

    def world(self, name_or_path: str) -> Path:
        """A shipped world name, or an SDF/.world path inside the workspace."""
        from fleet.paths import world_file

        _checked(name_or_path)
        if NAME_RE.match(name_or_path) and not name_or_path.endswith((".world", ".sdf")):
            return world_file(name_or_path)
        if not name_or_path.endswith((".world", ".sdf")):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"'{name_or_path}' is neither a world name nor a .world/.sdf "
                             "path", "call list_worlds for the shipped worlds")
        return self.read(name_or_path, "world file")

    def robot(self, name_or_path: str) -> str:
        """A shipped robot model name, a robot .yaml/.urdf/.urdf.xacro path inside the workspace, or URDF text
        (whose mesh URIs pass the sim's read policy)."""
        from fleet.paths import ROBOT_SUFFIXES, robot_file
        from sim.robot_load import is_robot_text

        if is_robot_text(name_or_path):
            return name_or_path
        _checked(name_or_path)
        if NAME_RE.match(name_or_path) and not name_or_path.endswith(ROBOT_SUFFIXES):
            return str(robot_file(name_or_path))
        if not name_or_path.endswith(ROBOT_SUFFIXES):
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"'{name_or_path}' is neither a robot model name nor a "
                             ".yaml/.urdf/.urdf.xacro path", "list_models / configs/robots for the shipped models")
        return str(self.read(name_or_path, "robot model"))

    def named(self, folder: str, name_or_path: str, what: str) -> Path:
        """A shipped config by name (configs/<folder>/<name>.yaml, as the CLI resolves it) or a YAML path
        inside the workspace."""
        _checked(name_or_path)
        if NAME_RE.match(name_or_path) and not name_or_path.endswith((".yaml", ".yml")):
            cand = self.shipped / folder / f"{name_or_path}.yaml"
            if cand.is_file():
                return cand
            known = sorted(f.stem for f in (self.shipped / folder).glob("*.yaml"))
            raise FleetError(ErrorCode.NOT_FOUND, f"no {what} named '{name_or_path}'",
                             f"shipped: {', '.join(known) or '(none)'}; or a .yaml path in the workspace")
        return self.read(name_or_path, what)

    # ---- writes ------------------------------------------------------------------------------------------

    def write_path(self, path: str | Path) -> Path:
        """Where a write of `path` goes: inside the outputs area, never over a file the server did not write."""
        p = Path(_checked(path))
        if p.is_absolute():
            full = p.resolve()
        else:
            rel = Path(*p.parts[1:]) if p.parts[:1] == ("outputs",) else p
            full = (self.outputs / rel).resolve()
        if not _inside(full, self.outputs.resolve() if self.outputs.exists() else self.outputs):
            raise FleetError(ErrorCode.PATH_NOT_ALLOWED, f"cannot write '{path}': writes go only to the outputs area "
                             f"{self.outputs}", "give a path relative to the outputs area, e.g. maps/a.yaml")
        if full.is_file() and full not in self.written():
            raise FleetError(ErrorCode.PATH_NOT_ALLOWED, f"'{path}' exists and was not written by this server",
                             "pass overwrite: true to replace it, or pick another name")
        self.outputs.mkdir(parents=True, exist_ok=True)
        self._remember(full)
        return full

    def write_folder(self, path: str | Path) -> Path:
        """A folder in the outputs area that a tool fills with several files: refused if it holds a file this
        server did not write (the same rule as `write_path`, applied to what is inside)."""
        full = self.write_path(path)
        if full.is_dir():
            written = self.written()
            foreign = sorted(f for f in full.rglob("*") if f.is_file() and f.resolve() not in written)
            if foreign:
                raise FleetError(ErrorCode.PATH_NOT_ALLOWED, f"'{path}' holds files this server did not write "
                                 f"({foreign[0].name}{', ...' if len(foreign) > 1 else ''})", "pick another folder")
        full.mkdir(parents=True, exist_ok=True)
        return full

    def remember_tree(self, folder: Path) -> None:
        """Record every file under `folder` as written by this server (after a tool filled it)."""
        for f in folder.rglob("*"):
            if f.is_file():
                self._remember(f.resolve())

    def permit_overwrite(self, path: str | Path) -> None:
        """The caller said `overwrite: true`: the next write of `path` may replace an existing file."""
        p = Path(_checked(path))
        rel = Path(*p.parts[1:]) if p.parts[:1] == ("outputs",) else p
        full = p.resolve() if p.is_absolute() else (self.outputs / rel).resolve()
        if _inside(full, self.outputs.resolve() if self.outputs.exists() else self.outputs):
            self.written().add(full)

    def written(self) -> set[Path]:
        if self._written is None:
            m = self.outputs / MANIFEST
            lines = m.read_text(encoding="utf-8").splitlines() if m.is_file() else []
            self._written = {Path(line) for line in lines if line}
        return self._written

    def _remember(self, full: Path) -> None:
        written = self.written()
        if full in written:
            return
        written.add(full)
        try:
            with (self.outputs / MANIFEST).open("a", encoding="utf-8") as f:
                f.write(f"{full}\n")
        except OSError:  # the manifest only lets a later server overwrite its own files
            pass
