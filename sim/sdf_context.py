"""State shared while one SDF document (and the model files it includes) is read: the model path, the
list of unsupported elements, the include stack (to catch cycles), and child-element bookkeeping.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np

from sim.errors import ErrorCode, FleetError
from sim.sdf_xml import Node
from sim.types import Pose3D


@dataclass
class ParseContext:
    search: list[Path]
    unsupported: dict[str, None] = field(default_factory=dict)  # an ordered set: each entry once
    include_stack: list[Path] = field(default_factory=list)
    # Memo for repeated includes (a shelf included 700 times is found, read and parsed once).
    memo: dict[tuple[object, ...], object] = field(default_factory=dict)

    def note(self, path: str, why: str = "") -> None:
        self.unsupported[f"{path}: {why}" if why else path] = None

    def check_children(self, node: Node, path: str, used: frozenset[str], ignored: frozenset[str]) -> None:
        """Note each child element that is neither used nor knowingly ignored (rendering-only)."""
        for c in node.children:
            if c.tag not in used and c.tag not in ignored:
                self.note(f"{path}/{c.tag}")


@lru_cache(maxsize=256)
def _base_dir(source: str) -> Path:
    p = Path(source)
    return p.parent.resolve() if p.is_file() else Path.cwd()


def base_dir(node: Node) -> Path:
    """The directory relative URIs in `node` are resolved against: its file's, or the cwd for strings."""
    return _base_dir(node.source)


def named(node: Node, kind: str, index: int | None = None) -> str:
    """The element's `name` attribute; SDF requires one on models, links and lights, collisions/visuals
    get a generated one (`collision_0`) when a file omits it."""
    name = node.attrib.get("name", "").strip()
    if name:
        return name
    if index is not None:
        return f"{kind}_{index}"
    raise FleetError(ErrorCode.INVALID_CONFIG, f"{node.where()}: <{node.tag}> has no name attribute",
                     f"give the {kind} a unique name=\"...\"")


def compose(a: Pose3D, b: Pose3D) -> Pose3D:
    """a ⊕ b, returning an operand unchanged when the other is the identity (keeps file values exact)."""
    if a == Pose3D():
        return b
    if b == Pose3D():
        return a
    return a.compose(b)


def inverse(a: Pose3D) -> Pose3D:
    return a if a == Pose3D() else Pose3D.from_matrix(np.linalg.inv(a.matrix()))
