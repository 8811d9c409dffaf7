"""A small XML tree with line numbers, and typed value readers whose errors name file, line and element.

xml.etree drops source positions, so the SDF loader builds this tree itself with expat: every error a user
sees then points at `<file>:<line>`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from xml.parsers import expat

from sim.errors import ErrorCode, FleetError
from sim.transforms import quat_to_rpy
from sim.types import Pose3D


@dataclass(eq=False)
class Node:
    tag: str
    attrib: dict[str, str]
    line: int
    source: str  # the file this element was read from (included models have their own)
    children: list[Node] = field(default_factory=list)
    text: str = ""

    def find(self, tag: str) -> Node | None:
        return next((c for c in self.children if c.tag == tag), None)

    def findall(self, tag: str) -> list[Node]:
        return [c for c in self.children if c.tag == tag]

    def child_text(self, tag: str) -> str | None:
        c = self.find(tag)
        return None if c is None else c.text.strip()

    def where(self) -> str:
        return f"{self.source}:{self.line}"


def parse_xml(text: str, source: str) -> Node:
    """Parse `text` into a Node tree; malformed XML is an INVALID_CONFIG error naming file and line."""
    root: list[Node] = []
    stack: list[Node] = []
    parser = expat.ParserCreate()

    def start(tag: str, attrib: dict[str, str]) -> None:
        node = Node(tag, attrib, parser.CurrentLineNumber, source)
        (stack[-1].children if stack else root).append(node)
        stack.append(node)

    def end(_tag: str) -> None:
        stack.pop()

    def chars(data: str) -> None:
        if stack:
            stack[-1].text += data

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.CharacterDataHandler = chars
    try:
        parser.Parse(text, True)
    except expat.ExpatError as exc:
        raise FleetError(ErrorCode.INVALID_CONFIG,
                         f"{source}:{exc.lineno}:{exc.offset + 1}: malformed XML: {expat.ErrorString(exc.code)}",
                         "fix the XML syntax at that line") from exc
    return root[0]


def bad_value(node: Node, what: str, hint: str = "") -> FleetError:
    return FleetError(ErrorCode.INVALID_CONFIG,
                      f"{node.where()}: <{node.tag}> must be {what}, got '{node.text.strip()}'", hint)


def floats(node: Node, n: int | tuple[int, ...]) -> list[float]:
    """The whitespace-separated numbers of `node`; exactly `n` of them (or one of the counts in `n`)."""
    counts = (n,) if isinstance(n, int) else n
    try:
        vals = [float(t) for t in node.text.split()]
    except ValueError:
        vals = []
    if len(vals) not in counts or not all(math.isfinite(v) for v in vals):
        raise bad_value(node, " or ".join(str(c) for c in counts) + " finite number(s)")
    return vals


def child_float(node: Node, tag: str, default: float, *, positive: bool = False,
                non_negative: bool = False) -> float:
    c = node.find(tag)
    if c is None:
        return default
    v = floats(c, 1)[0]
    if positive and v <= 0:
        raise bad_value(c, "a positive number")
    if non_negative and v < 0:
        raise bad_value(c, "a non-negative number")
    return v


def child_vec(node: Node, tag: str, n: int, default: tuple[float, ...]) -> tuple[float, ...]:
    c = node.find(tag)
    return default if c is None else tuple(floats(c, n))


def child_bool(node: Node, tag: str, default: bool) -> bool:
    c = node.find(tag)
    if c is None:
        return default
    t = c.text.strip().lower()
    if t in ("1", "true"):
        return True
    if t in ("0", "false"):
        return False
    raise bad_value(c, "a boolean (true/false/1/0)")


def read_pose(node: Node | None) -> Pose3D:
    """An SDF <pose>: `x y z roll pitch yaw`, SDF 1.9 `degrees="true"` and `rotation_format="quat_xyzw"`."""
    if node is None or not node.text.strip():
        return Pose3D()
    if node.attrib.get("rotation_format", "euler_rpy") == "quat_xyzw":
        v = floats(node, 7)
        r, p, y = quat_to_rpy(v[3:7])
        return Pose3D(v[0], v[1], v[2], r, p, y)
    v = floats(node, 6)
    if node.attrib.get("degrees", "false").strip().lower() in ("1", "true"):
        v[3:] = [math.radians(a) for a in v[3:]]
    return Pose3D(*v)


def rgba(node: Node) -> tuple[float, float, float, float]:
    v = floats(node, (3, 4))
    return (v[0], v[1], v[2], v[3] if len(v) == 4 else 1.0)
