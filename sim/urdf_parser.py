"""Read a URDF file into sim.urdf_model dataclasses: links, joints, Gazebo sensors and plugins.

Errors name the file and line: XML is read with expat directly because ElementTree drops line numbers.
Unexpanded xacro is refused with a hint rather than half-read.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from xml.parsers import expat

from sim.errors import ErrorCode, FleetError
from sim.inertia import Inertia
from sim.read_policy import allowed, policy_active
from sim.types import Box, Cylinder, Geometry, Mesh, Pose3D, Sphere
from sim.urdf_model import (
    JOINT_TYPES,
    ContactFriction,
    JointLimit,
    UrdfInertial,
    UrdfJoint,
    UrdfLink,
    UrdfPlugin,
    UrdfRobot,
    UrdfSensor,
    UrdfShape,
)

__all__ = ["UrdfRobot", "parse_urdf"]
_ZERO = Pose3D()


@dataclass
class _Node:
    tag: str
    attrib: dict[str, str]
    line: int
    children: list[_Node] = field(default_factory=list)
    text: str = ""

    def find(self, path: str) -> _Node | None:
        node: _Node | None = self
        for tag in path.split("/"):
            node = next((c for c in node.children if c.tag == tag), None) if node else None
        return node

    def all(self, tag: str) -> list[_Node]:
        return [c for c in self.children if c.tag == tag]


class _Reader:
    """Turns the node tree into the model; every error names `source` and the element's line."""

    def __init__(self, source: str) -> None:
        self.source = source

    def error(self, node: _Node | int, message: str, hint: str = "see the URDF specification") -> FleetError:
        line = node if isinstance(node, int) else node.line
        return FleetError(ErrorCode.INVALID_CONFIG, f"{self.source}:{line}: {message}", hint)

    def tree(self, text: str) -> _Node:
        stack: list[_Node] = [_Node("#document", {}, 0)]
        parser = expat.ParserCreate()

        def start(tag: str, attrib: dict[str, str]) -> None:
            node = _Node(tag, attrib, parser.CurrentLineNumber)
            if tag.startswith("xacro:"):
                raise self.error(node, f"<{tag}> is xacro, not URDF",
                                 "expand it first: xacro in.xacro > out.urdf")
            stack[-1].children.append(node)
            stack.append(node)

        def end(_tag: str) -> None:
            stack.pop()

        def chars(data: str) -> None:
            stack[-1].text += data

        parser.StartElementHandler, parser.EndElementHandler, parser.CharacterDataHandler = start, end, chars
        try:
            parser.Parse(text, True)
        except expat.ExpatError as exc:
            raise self.error(exc.lineno, f"malformed XML: {expat.errors.messages[exc.code]} "
                             f"(column {exc.offset + 1})", "fix the XML at that line") from exc
        return stack[0].children[0]

    def floats(self, node: _Node, attr: str, n: int,
               default: tuple[float, ...] | None = None) -> tuple[float, ...]:
        raw = node.attrib.get(attr)
        if raw is None:
            if default is None:
                raise self.error(node, f"<{node.tag}> needs a '{attr}' attribute")
            return default
        try:
            values = tuple(float(v) for v in raw.split())
        except ValueError:
            values = ()
        if len(values) != n or not all(math.isfinite(v) for v in values):
            raise self.error(node, f"<{node.tag} {attr}=\"{raw}\">: expected {n} finite number(s)")
        return values

    def vec3(self, node: _Node, attr: str,
             default: tuple[float, float, float] | None = None) -> tuple[float, float, float]:
        x, y, z = self.floats(node, attr, 3, default)
        return (x, y, z)

    def number(self, node: _Node | None, path: str) -> float | None:
        found = node.find(path) if node else None
        if found is None:
            return None
        try:
            return float(found.text.strip())
        except ValueError:
            raise self.error(found, f"<{found.tag}> holds '{found.text.strip()}', not a number") from None

    def origin(self, parent: _Node) -> Pose3D:
        node = parent.find("origin")
        if node is None:
            return _ZERO
        xyz = self.vec3(node, "xyz", (0.0, 0.0, 0.0))
        rpy = self.vec3(node, "rpy", (0.0, 0.0, 0.0))
        return Pose3D(*xyz, *rpy)

    def geometry(self, parent: _Node, base_dir: Path) -> Geometry:
        g = parent.find("geometry")
        shape = g.children[0] if g is not None and g.children else None
        if shape is None:
            raise self.error(parent, f"<{parent.tag}> needs a <geometry> with one shape")
        if shape.tag == "box":
            return Box(self.vec3(shape, "size"))
        if shape.tag == "cylinder":
            return Cylinder(self.floats(shape, "radius", 1)[0], self.floats(shape, "length", 1)[0])
        if shape.tag == "sphere":
            return Sphere(self.floats(shape, "radius", 1)[0])
        if shape.tag == "mesh":
            uri = shape.attrib.get("filename", "")
            path = uri.removeprefix("file://")
            resolved = str(base_dir / path) if not uri.startswith("package://") else uri
            if not uri.startswith("package://") and not readable(Path(resolved)):
                raise self.error(shape, f"cannot find mesh '{uri}'", "meshes must be inside the workspace")
            return Mesh(uri, resolved, self.vec3(shape, "scale", (1.0, 1.0, 1.0)))
        raise self.error(shape, f"unknown geometry <{shape.tag}>", "use box, cylinder, sphere or mesh")

    def link(self, node: _Node, base_dir: Path) -> UrdfLink:
        name = node.attrib.get("name") or ""
        inertial = None
        if (inode := node.find("inertial")) is not None:
            mass_node = inode.find("mass")
            mass = self.floats(mass_node, "value", 1)[0] if mass_node else 0.0
            if mass < 0:
                raise self.error(mass_node or inode, f"link '{name}' has a negative mass ({mass} kg)")
            i_node = inode.find("inertia")
            keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
            values = [self.floats(i_node, k, 1, (0.0,))[0] for k in keys] if i_node else [0.0] * 6
            inertial = UrdfInertial(mass, self.origin(inode), Inertia(*values))
        visuals = tuple(UrdfShape(v.attrib.get("name", ""), self.geometry(v, base_dir), self.origin(v),
                                  self.rgba(v)) for v in node.all("visual"))
        collisions = tuple(UrdfShape(c.attrib.get("name", ""), self.geometry(c, base_dir), self.origin(c))
                           for c in node.all("collision"))
        contact = None
        if (cnode := node.find("contact")) is not None:
            def value(tag: str) -> float | None:
                n = cnode.find(tag)
                return self.floats(n, "value", 1)[0] if n else None
            contact = ContactFriction(value("lateral_friction"), value("rolling_friction"),
                                      value("spinning_friction"))
        return UrdfLink(name, inertial, visuals, collisions, contact, {}, node.line)

    def rgba(self, visual: _Node) -> tuple[float, float, float, float] | None:
        color = visual.find("material/color")
        if color is None:
            return None
        r, g, b, a = self.floats(color, "rgba", 4)
        return (r, g, b, a)

    def joint(self, node: _Node, links: dict[str, UrdfLink]) -> UrdfJoint:
        name, kind = node.attrib.get("name", ""), node.attrib.get("type", "")
        if kind not in JOINT_TYPES:
            raise self.error(node, f"joint '{name}' has type '{kind}'",
                             f"valid types: {', '.join(JOINT_TYPES)}")
        ends = []
        for role in ("parent", "child"):
            ref = node.find(role)
            link = ref.attrib.get("link", "") if ref else ""
            if link not in links:
                raise self.error(ref or node, f"joint '{name}' names {role} link '{link}', which is not "
                                 "defined", f"links: {', '.join(links)}")
            ends.append(link)
        axis_node = node.find("axis")
        axis = self.vec3(axis_node, "xyz", (1.0, 0.0, 0.0)) if axis_node else (1.0, 0.0, 0.0)
        if not any(axis):
            raise self.error(axis_node or node, f"joint '{name}' has a zero axis")
        limit = None
        if (lim := node.find("limit")) is not None:
            def opt(attr: str) -> float | None:
                return self.floats(lim, attr, 1)[0] if attr in lim.attrib else None
            limit = JointLimit(opt("lower"), opt("upper"), opt("effort"), opt("velocity"))
        return UrdfJoint(name, kind, ends[0], ends[1], self.origin(node), axis, limit, node.line)

    def plugin(self, node: _Node) -> UrdfPlugin:
        params: list[tuple[str, str]] = []

        def walk(n: _Node, prefix: str) -> None:
            for c in n.children:
                key = prefix + c.tag
                if c.children:
                    walk(c, key + "/")
                else:
                    params.append((key, c.text.strip()))
        walk(node, "")
        return UrdfPlugin(node.attrib.get("name", ""), node.attrib.get("filename", ""), tuple(params))

    def sensor(self, node: _Node, link: str) -> UrdfSensor:
        ray = node.find("ray") or node.find("lidar")
        cam = node.find("camera")
        scan = ray.find("scan/horizontal") if ray else None
        noisy = (ray, cam, node.find("imu/angular_velocity/x"))
        noise = next((n for n in noisy if n and n.find("noise")), None)
        samples = self.number(scan, "samples")
        width, height = self.number(cam, "image/width"), self.number(cam, "image/height")
        fmt = cam.find("image/format") if cam else None
        return UrdfSensor(
            node.attrib.get("name", ""), node.attrib.get("type", ""), link, self.number(node, "update_rate"),
            int(samples) if samples is not None else None, self.number(scan, "resolution"),
            self.number(scan, "min_angle"), self.number(scan, "max_angle"),
            self.number(ray, "range/min") if ray else self.number(cam, "clip/near"),
            self.number(ray, "range/max") if ray else self.number(cam, "clip/far"),
            self.number(cam, "horizontal_fov"), int(width) if width is not None else None,
            int(height) if height is not None else None, fmt.text.strip() if fmt else None,
            self.number(noise, "noise/stddev"), tuple(self.plugin(p) for p in node.all("plugin")), node.line,
            self.number(node.find("imu/linear_acceleration/x"), "noise/stddev"), self.sensor_pose(node))

    def sensor_pose(self, node: _Node) -> Pose3D:
        pose = node.find("pose")
        if pose is None or not pose.text.strip():
            return _ZERO
        try:
            values = [float(v) for v in pose.text.split()]
        except ValueError:
            values = []
        if len(values) != 6 or not all(math.isfinite(v) for v in values):
            raise self.error(pose, f"<pose>{pose.text.strip()}</pose>: expected 6 finite numbers (x y z roll "
                             "pitch yaw)")
        return Pose3D(*values)

    def robot(self, root: _Node, base_dir: Path) -> UrdfRobot:
        if root.tag != "robot":
            raise self.error(root, f"the root element is <{root.tag}>, not <robot>")
        links: dict[str, UrdfLink] = {}
        for node in root.all("link"):
            link = self.link(node, base_dir)
            if not link.name or link.name in links:
                what = f"duplicate link name '{link.name}'" if link.name else "a <link> without a name"
                raise self.error(node, what, "every link needs a unique name")
            links[link.name] = link
        if not links:
            raise self.error(root, "the robot has no <link>")
        joints: dict[str, UrdfJoint] = {}
        for node in root.all("joint"):
            joint = self.joint(node, links)
            if not joint.name or joint.name in joints:
                raise self.error(node, f"duplicate or missing joint name '{joint.name}'")
            if any(j.child == joint.child for j in joints.values()):
                raise self.error(node, f"link '{joint.child}' is the child of two joints", "a URDF is a tree")
            joints[joint.name] = joint
        self.check_tree(root, links, joints)
        sensors, plugins = self.gazebo(root, links, joints)
        return UrdfRobot(root.attrib.get("name", ""), links, joints, sensors, plugins, self.source)

    def check_tree(self, root: _Node, links: dict[str, UrdfLink], joints: dict[str, UrdfJoint]) -> None:
        children = {j.child for j in joints.values()}
        roots = [n for n in links if n not in children]
        if len(roots) != 1:
            found = ", ".join(roots) or "none (a loop)"
            raise self.error(root, f"expected one root link, found {found}",
                             "connect every link to one root with joints")
        # Each link has at most one parent here, so a walk from the root ends, and what it misses is a loop.
        reached, frontier = set(), [roots[0]]
        while frontier:
            reached.add(name := frontier.pop())
            frontier += [j.child for j in joints.values() if j.parent == name and j.child not in reached]
        if unreached := [n for n in links if n not in reached]:
            raise self.error(links[unreached[0]].line, f"links {', '.join(unreached)} form a loop "
                             f"unconnected to the root '{roots[0]}'", "a URDF is a tree")

    def gazebo(self, root: _Node, links: dict[str, UrdfLink],
               joints: dict[str, UrdfJoint]) -> tuple[tuple[UrdfSensor, ...], tuple[UrdfPlugin, ...]]:
        sensors: list[UrdfSensor] = []
        plugins: list[UrdfPlugin] = []
        for node in root.all("gazebo"):
            ref = node.attrib.get("reference")
            if ref is None:
                plugins += [self.plugin(p) for p in node.all("plugin")]
                continue
            if ref not in links and ref not in joints:
                raise self.error(node, f"<gazebo reference=\"{ref}\"> names no link or joint")
            sensors += [self.sensor(s, ref) for s in node.all("sensor")]
            if ref in links:
                extra = {c.tag: c.text.strip() for c in node.children if not c.children}
                links[ref] = replace(links[ref], gazebo={**links[ref].gazebo, **extra})
        return tuple(sensors), tuple(plugins)


def parse_urdf(source: str | Path, *, name: str = "<string>", base_dir: Path | None = None) -> UrdfRobot:
    """Parse URDF text (a string starting with '<') or a file path. Problems raise FleetError naming the
    file and line: INVALID_CONFIG for bad content, NOT_FOUND for an unreadable file. Text gets `name` in
    messages and resolves relative mesh paths from `base_dir` (default: the working directory)."""
    if isinstance(source, str) and source.lstrip().startswith("<"):
        text, base_dir = source, base_dir or Path.cwd()
    else:
        path = Path(source)
        try:
            text = path.read_text(encoding="utf-8")
        except OSError as exc:
            raise FleetError(ErrorCode.NOT_FOUND, f"cannot read {path}: {exc.strerror}",
                             "check the path") from exc
        name, base_dir = str(path), path.resolve().parent
    reader = _Reader(name)
    return reader.robot(reader.tree(text), base_dir)


def readable(path: Path) -> bool:
    """Under a read policy a mesh must exist and be allowed (both failures answer alike); else anything goes."""
    return not policy_active() or (path.resolve().is_file() and allowed(path.resolve()))
