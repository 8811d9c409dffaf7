"""One SDF <model> (or <include> of one) → links with poses in the model frame.

Nested models are flattened into links named `inner::link` with composed poses. Poses may be
`relative_to` any frame of the model's scope (the model, a link, a nested model or a <frame>, SDF 1.7+);
frames are resolved lazily so they may refer to frames declared later.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import cast

from sim.errors import ErrorCode, FleetError
from sim.sdf_context import ParseContext, base_dir, compose, inverse, named
from sim.sdf_geometry import parse_friction, parse_geometry, parse_material
from sim.sdf_paths import read_text, resolve_include
from sim.sdf_xml import Node, child_bool, child_float, parse_xml, read_pose
from sim.types import Collision, Geometry, Link, Pose3D, Visual

MODEL_USED = frozenset({"static", "pose", "link", "model", "include", "frame"})
MODEL_IGNORED = frozenset({"self_collide", "allow_auto_disable", "enable_wind"})
LINK_USED = frozenset({"pose", "inertial", "collision", "visual", "gravity", "kinematic"})
LINK_IGNORED = frozenset({"self_collide", "must_be_base_link", "enable_wind", "velocity_decay"})
PART_USED = frozenset({"geometry", "pose", "surface", "material"})
PART_IGNORED = frozenset({"laser_retro", "max_contacts", "cast_shadows", "transparency", "meta"})
INCLUDE_USED = frozenset({"uri", "name", "pose", "static"})
MODEL = "__model__"


@dataclass
class ParsedModel:
    name: str
    pose: Pose3D  # as written (relative to `relative_to`, or to the parent frame)
    relative_to: str | None
    static: bool
    static_explicit: bool  # the file (or the include) said <static>
    links: list[Link]  # poses in this model's frame
    frames: dict[str, Pose3D]  # every named frame of the model's scope, in this model's frame
    source: str = ""
    has_collision: bool = False
    ground_textures: list[str] = field(default_factory=list)  # albedo maps of plane visuals


@dataclass
class _Part:
    kind: str  # collision | visual
    name: str
    geometry: Geometry
    pose: Pose3D
    relative_to: str | None
    friction: float | None = None
    rgba: tuple[float, float, float, float] = (0.7, 0.7, 0.7, 1.0)
    material: str | None = None


def open_include(node: Node, ctx: ParseContext) -> tuple[Node, Path, str]:
    """The root element of the file an <include> names (found through the model path), its path and URI."""
    uri = node.child_text("uri")
    if not uri:
        raise FleetError(ErrorCode.INVALID_CONFIG, f"{node.where()}: <include> needs a <uri>")
    key = ("file", uri, base_dir(node))
    if key not in ctx.memo:
        path = resolve_include(uri, node, base_dir(node), ctx.search)
        ctx.memo[key] = (path, parse_xml(read_text(path, node), str(path)))
    path, root = cast(tuple[Path, Node], ctx.memo[key])
    if path in ctx.include_stack:
        raise FleetError(ErrorCode.INVALID_CONFIG, f"{node.where()}: include cycle through '{uri}'")
    return root, path, uri


def include_model(node: Node, ctx: ParseContext, parent_path: str,
                  opened: tuple[Node, Path, str] | None = None, default_static: bool = False) -> ParsedModel:
    """An <include> of a model, with the include's name/pose/static overrides applied."""
    root, path, uri = opened or open_include(node, ctx)
    model = root if root.tag == "model" else root.find("model")
    if model is None:
        raise FleetError(ErrorCode.INVALID_CONFIG, f"{node.where()}: included file {path} holds no <model>")
    name = node.child_text("name") or named(model, "model")
    ctx.check_children(node, f"{parent_path}/model[{name}]", INCLUDE_USED, frozenset())
    said = node.find("static") is not None or model.find("static") is not None
    static = child_bool(node, "static", child_bool(model, "static", False)) if said else None
    pose_node = node.find("pose")
    pose_node = pose_node if pose_node is not None else model.find("pose")
    key = ("model", path, static, default_static)
    if key in ctx.memo:  # same file, same static: same links; only the name and pose differ
        done = cast(ParsedModel, ctx.memo[key])
        return replace(done, name=name, pose=read_pose(pose_node), relative_to=_relative_to(pose_node),
                       links=list(done.links), frames=dict(done.frames), ground_textures=list(done.ground_textures))
    notes = len(ctx.unsupported)
    ctx.include_stack.append(path)
    try:
        out = parse_model(model, ctx, parent_path, name=name, pose_node=pose_node, static=static, source=uri,
                          default_static=default_static)
    finally:
        ctx.include_stack.pop()
    if len(ctx.unsupported) == notes:  # reuse only when nothing was noted (notes name the model)
        ctx.memo[key] = out
    return out


def parse_model(node: Node, ctx: ParseContext, parent_path: str, *, name: str | None = None,
                pose_node: Node | None = None, static: bool | None = None, source: str = "",
                default_static: bool = False) -> ParsedModel:
    name = name or named(node, "model")
    path = f"{parent_path}/model[{name}]"
    ctx.check_children(node, path, MODEL_USED, MODEL_IGNORED)
    is_static = child_bool(node, "static", default_static) if static is None else static
    pose_node = pose_node if pose_node is not None else node.find("pose")
    out = ParsedModel(name, read_pose(pose_node), _relative_to(pose_node), is_static,
                      static is not None or node.find("static") is not None, [], {}, source)
    entries: dict[str, tuple[Pose3D, str, Node]] = {}
    items: list[tuple[str, Node, ParsedModel | None]] = []  # document order of links and nested models
    for c in node.children:
        if c.tag == "link":
            ln = named(c, "link")
            _unique(entries, ln, c)
            entries[ln] = (read_pose(c.find("pose")), _relative_to(c.find("pose")) or MODEL, c)
            items.append((ln, c, None))
        elif c.tag in ("model", "include"):
            child = (parse_model(c, ctx, path, default_static=is_static) if c.tag == "model"
                     else include_model(c, ctx, path, default_static=is_static))
            if child.static_explicit and child.static != is_static:
                ctx.note(f"{path}/model[{child.name}]/static", f"nested models take the parent's static={is_static}")
            _unique(entries, child.name, c)
            entries[child.name] = (child.pose, child.relative_to or MODEL, c)
            for fname, fpose in child.frames.items():
                entries[f"{child.name}::{fname}"] = (fpose, child.name, c)
            items.append((child.name, c, child))
            out.has_collision |= child.has_collision
            out.ground_textures += child.ground_textures
        elif c.tag == "frame":
            fn = named(c, "frame")
            _unique(entries, fn, c)
            pn = c.find("pose")
            entries[fn] = (read_pose(pn), _relative_to(pn) or c.attrib.get("attached_to") or MODEL, c)
    frames = FrameResolver(entries, MODEL)
    out.frames = {k: frames.get(k, entries[k][2]) for k in entries}
    for item_name, item_node, sub in items:
        if sub is None:
            out.links.append(_link(item_node, item_name, out.frames[item_name], frames, ctx, path, out))
        else:
            base = out.frames[item_name]
            out.links += [Link(f"{item_name}::{lk.name}", compose(base, lk.pose), lk.mass, lk.inertia,
                               lk.collisions, lk.visuals) for lk in sub.links]
    return out


def _unique(entries: dict[str, tuple[Pose3D, str, Node]], name: str, node: Node) -> None:
    if name in entries:
        raise FleetError(ErrorCode.INVALID_CONFIG, f"{node.where()}: duplicate name '{name}' in this model",
                         "links, nested models and frames of a model need unique names")


def _relative_to(pose_node: Node | None) -> str | None:
    return None if pose_node is None else (pose_node.attrib.get("relative_to") or None)


class FrameResolver:
    """Poses of named frames in the scope's frame (`root`: __model__ or world), each resolved once along
    its relative_to chain."""

    def __init__(self, entries: dict[str, tuple[Pose3D, str, Node]], root: str) -> None:
        self._entries = entries
        self._root = root
        self._done: dict[str, Pose3D] = {root: Pose3D()}

    def get(self, name: str, ref: Node, chain: tuple[str, ...] = ()) -> Pose3D:
        if name in self._done:
            return self._done[name]
        if name in chain:
            raise FleetError(ErrorCode.INVALID_CONFIG, f"{ref.where()}: relative_to cycle: {' → '.join(chain)}")
        if name not in self._entries:
            names = sorted(self._entries)
            known = ", ".join(names[:20]) + (f" and {len(names) - 20} more" if len(names) > 20 else "")
            raise FleetError(ErrorCode.INVALID_CONFIG, f"{ref.where()}: relative_to '{name}' names no frame "
                             "in this scope", f"frames in scope: {self._root}, {known}")
        pose, rel, node = self._entries[name]
        self._done[name] = compose(self.get(rel, node, (*chain, name)), pose)
        return self._done[name]


def _link(node: Node, name: str, pose: Pose3D, frames: FrameResolver, ctx: ParseContext, model_path: str,
          model: ParsedModel) -> Link:
    path = f"{model_path}/link[{name}]"
    ctx.check_children(node, path, LINK_USED, LINK_IGNORED)
    if not child_bool(node, "gravity", True):
        ctx.note(f"{path}/gravity", "gravity is always on")
    if child_bool(node, "kinematic", False):
        ctx.note(f"{path}/kinematic")
    mass, inertia = _inertial(node.find("inertial"), model.static, path, ctx)
    parts = [p for i, c in enumerate(node.children) if c.tag in ("collision", "visual")
             if (p := _part(c, i, path, ctx, model)) is not None]
    to_link = inverse(pose)
    collisions, visuals = [], []
    for p in parts:
        local = p.pose if p.relative_to in (None, name) else compose(
            to_link, compose(frames.get(p.relative_to or MODEL, node), p.pose))
        if p.kind == "collision":
            collisions.append(Collision(p.name, p.geometry, local, p.friction))
            model.has_collision = True
        else:
            visuals.append(Visual(p.name, p.geometry, local, p.rgba, p.material))
    return Link(name, pose, mass, inertia, tuple(collisions), tuple(visuals))


def _inertial(node: Node | None, static: bool, path: str, ctx: ParseContext) -> tuple[
        float, tuple[float, float, float, float, float, float]]:
    if node is None:  # SDF defaults for a dynamic link; static links have no mass
        return (0.0, (0, 0, 0, 0, 0, 0)) if static else (1.0, (1.0, 0.0, 0.0, 1.0, 0.0, 1.0))
    ctx.check_children(node, f"{path}/inertial", frozenset({"mass", "inertia", "pose"}), frozenset())
    if read_pose(node.find("pose")) != Pose3D():
        ctx.note(f"{path}/inertial/pose", "the centre of mass is taken at the link origin")
    mass = child_float(node, "mass", 1.0, non_negative=True)
    if mass == 0 and not static:
        raise FleetError(ErrorCode.INVALID_CONFIG, f"{node.where()}: a non-static link needs a mass > 0",
                         "set <mass> or make the model <static>true</static>")
    i = node.find("inertia")
    keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    defaults = (1.0, 0.0, 0.0, 1.0, 0.0, 1.0)
    vals = tuple(child_float(i, k, d) for k, d in zip(keys, defaults, strict=True)) if i is not None else defaults
    return mass, (vals[0], vals[1], vals[2], vals[3], vals[4], vals[5])


def _part(node: Node, index: int, link_path: str, ctx: ParseContext, model: ParsedModel) -> _Part | None:
    name = named(node, node.tag, index)
    path = f"{link_path}/{node.tag}[{name}]"
    used = PART_USED - ({"material"} if node.tag == "collision" else {"surface"})
    ctx.check_children(node, path, used, PART_IGNORED)
    geo_node = node.find("geometry")
    if geo_node is None:
        raise FleetError(ErrorCode.INVALID_CONFIG, f"{node.where()}: <{node.tag}> '{name}' has no <geometry>")
    geometry = parse_geometry(geo_node, path, ctx)
    if geometry is None:
        return None
    pn = node.find("pose")
    part = _Part(node.tag, name, geometry, read_pose(pn), _relative_to(pn))
    if node.tag == "collision":
        surface = node.find("surface")
        if surface is not None:  # only Coulomb friction maps onto PyBullet; bounce/contact stiffness do not
            ctx.check_children(surface, f"{path}/surface", frozenset({"friction"}), frozenset())
        part.friction = parse_friction(surface)
    else:
        part.rgba, part.material, texture = parse_material(node.find("material"), path, ctx)
        if texture is not None and geometry.kind == "plane":
            model.ground_textures.append(texture)
        elif texture is not None:
            ctx.note(f"{path}/material/pbr", "textures are applied to the ground plane only")
    return part
