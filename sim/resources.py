"""The one place that locates fleetnav's shipped data: the top-level `configs/` folder, which the wheel
installs as the `configs` package (pyproject: package data) and importlib.resources finds from any working
directory, editable install or not. Everything else asks `shipped(...)` instead of walking up from __file__.
"""

from __future__ import annotations

from functools import cache
from importlib import resources
from pathlib import Path

from sim.errors import ErrorCode, FleetError

PACKAGE = "configs"


@cache
def shipped_root() -> Path:
    """The directory holding robots/, worlds/, models/, missions/, challenges/, zenoh/ ..."""
    try:
        root = resources.files(PACKAGE)
    except ModuleNotFoundError:  # a source tree without the package installed: the folder beside sim/
        return Path(__file__).resolve().parents[1] / PACKAGE
    # A regular package is a plain directory on disk (wheels are installed unzipped).
    path = Path(str(root))
    if not (path / "robots").is_dir():
        raise FleetError(ErrorCode.NOT_FOUND, f"fleetnav's shipped data is incomplete: no robots/ in {path}",
                         "reinstall fleetnav (the wheel carries configs/ as package data)")
    return path


def shipped(*parts: str) -> Path:
    """A shipped file or folder, e.g. shipped("robots", "diffbot.yaml") (it may not exist: callers check)."""
    return shipped_root().joinpath(*parts)
