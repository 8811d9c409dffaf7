"""Expand xacro (the `xacro` package from PyPI, no ROS needed) into URDF text.

`$(find pkg)` resolves through sim.resource_path's package search path instead of ament/rospkg, and
includes resolve relative to the including file. xacro keeps module-level state, so expansions are
serialised by a lock.
"""

from __future__ import annotations

import threading
from pathlib import Path

from sim.errors import ErrorCode, FleetError
from sim.resource_path import HINT, find_package, package_search_path

_LOCK = threading.Lock()


def is_xacro_text(text: str) -> bool:
    return "xmlns:xacro" in text or "<xacro:" in text


def expand_xacro(source: str | Path, mappings: dict[str, str] | None = None,
                 package_path: list[Path] | None = None) -> str:
    """URDF text from a .xacro file path or xacro text (a string starting with '<')."""
    try:
        import xacro
        from xacro import substitution_args
    except ModuleNotFoundError as exc:  # a declared dependency; only a broken install lacks it
        raise FleetError(ErrorCode.NOT_FOUND, "the 'xacro' package is not installed", "pip install xacro") from exc
    search = package_path if package_path is not None else package_search_path()
    is_text = isinstance(source, str) and source.lstrip().startswith("<")
    name = "<string>" if is_text else str(source)

    missing: list[FleetError] = []  # xacro wraps what `find` raises: keep ours to re-raise it unwrapped

    def find(pkg: str) -> str:
        found = find_package(pkg, search)
        if found is None:
            missing.append(FleetError(ErrorCode.NOT_FOUND, f"{name}: xacro $(find {pkg}): no package '{pkg}'",
                                      f"searched: {', '.join(map(str, search)) or 'nothing'}; {HINT}"))
            raise missing[-1]
        return str(found)

    with _LOCK:
        saved = substitution_args._eval_find
        substitution_args._eval_find = find
        try:
            if is_text:
                xacro.init_stacks(None)
                doc = xacro.parse(str(source))
                xacro.process_doc(doc, mappings=mappings or {})
            else:
                path = Path(source).resolve()
                if not path.is_file():
                    raise FleetError(ErrorCode.NOT_FOUND, f"cannot read {source}: no such file", "check the path")
                doc = xacro.process_file(str(path), mappings=mappings or {})
            return str(doc.toprettyxml(indent="  "))
        except FleetError:
            raise
        except Exception as exc:  # xacro raises XacroException, ExpatError, NameError ... for bad input
            if missing:
                raise missing[-1] from exc
            raise FleetError(ErrorCode.INVALID_CONFIG, f"{name}: xacro failed: {exc}",
                             "run `xacro FILE` to see the full error") from exc
        finally:
            substitution_args._eval_find = saved
