"""Read Gazebo SDF (1.4–1.9) world files into a `WorldDescription`.

What is used and what is only listed in `WorldDescription.unsupported` is documented in docs/worlds.md.
Conventions (see sim.sdf_conventions): a world-level <frame> or a collision-free <model> whose name starts
with `spawn` is a spawn point, not a model; `goal*` / `dock_*` models are visual-only markers.
"""

from __future__ import annotations

from pathlib import Path

from sim.errors import ErrorCode, FleetError
from sim.sdf_context import ParseContext, named
from sim.sdf_conventions import is_spawn_name
from sim.sdf_model import FrameResolver, ParsedModel, include_model, open_include, parse_model
from sim.sdf_paths import model_search_path, read_text
from sim.sdf_xml import Node, child_bool, child_float, child_vec, parse_xml, read_pose, rgba
from sim.types import Light, ModelDescription, PhysicsSettings, Pose3D, SpawnPoint, WorldDescription

WORLD_USED = frozenset({"model", "include", "light", "physics", "gravity", "frame"})
WORLD_IGNORED = frozenset({"scene", "gui", "spherical_coordinates", "magnetic_field", "atmosphere", "wind",
                           "audio"})
LIGHT_USED = frozenset({"pose", "diffuse", "cast_shadows", "direction"})
LIGHT_IGNORED = frozenset({"specular", "attenuation", "spot", "intensity", "visualize", "light_on"})
PHYSICS_USED = frozenset({"max_step_size", "real_time_factor", "gravity"})
PHYSICS_IGNORED = frozenset({"real_time_update_rate", "max_contacts"})
WORLD = "world"


def parse_sdf(path: str | Path, model_path: list[str] | None = None) -> WorldDescription:
    """Load an SDF world file (or a model file: a one-model description)."""
    p = Path(path)
    return parse_sdf_string(read_text(p), source=str(p), model_path=model_path)


def parse_sdf_string(text: str, source: str = "<string>", model_path: list[str] | None = None) -> WorldDescription:
    root = parse_xml(text, source)
    ctx = ParseContext(model_search_path(model_path))
    if root.tag == "model":
        return _single_model(root, ctx, "1.9", source)
    if root.tag != "sdf":
        raise FleetError(ErrorCode.INVALID_CONFIG, f"{root.where()}: root element is <{root.tag}>, not <sdf>",
                         "an SDF file starts with <sdf version=\"1.9\">")
    version = root.attrib.get("version", "1.9")
    ctx.check_children(root, "sdf", frozenset({"world", "model"}), frozenset())
    world = root.find("world")
    if world is not None:
        return _world(world, ctx, version, source)
    model = root.find("model")
    if model is not None:
        return _single_model(model, ctx, version, source)
    raise FleetError(ErrorCode.INVALID_CONFIG, f"{root.where()}: <sdf> holds no <world> or <model>")


def _single_model(node: Node, ctx: ParseContext, version: str, source: str) -> WorldDescription:
    m = parse_model(node, ctx, "sdf")
    model = ModelDescription(m.name, m.pose, m.static, tuple(m.links), m.source)
    return WorldDescription(m.name, (model,), unsupported=tuple(ctx.unsupported), source=source,
                            sdf_version=version)


def _world(node: Node, ctx: ParseContext, version: str, source: str) -> WorldDescription:
    ctx.check_children(node, WORLD, WORLD_USED, WORLD_IGNORED)
    entries: dict[str, tuple[Pose3D, str, Node]] = {}
    parsed: list[tuple[ParsedModel, Node]] = []
    frames: list[tuple[str, Node]] = []
    lights: list[Light] = []
    for c in node.children:
        if c.tag in ("model", "include"):
            m = _model_or_light(c, ctx, lights)
            if m is None:
                continue
            _unique(entries, m.name, c)
            entries[m.name] = (m.pose, m.relative_to or WORLD, c)
            entries.update({f"{m.name}::{k}": (v, m.name, c) for k, v in m.frames.items()})
            parsed.append((m, c))
        elif c.tag == "frame":
            name = named(c, "frame")
            _unique(entries, name, c)
            pn = c.find("pose")
            rel = (pn.attrib.get("relative_to") if pn is not None else None) or c.attrib.get("attached_to")
            entries[name] = (read_pose(pn), rel or WORLD, c)
            frames.append((name, c))
        elif c.tag == "light":
            lights.append(_light(c, ctx, read_pose(c.find("pose"))))
    resolver = FrameResolver(entries, WORLD)
    spawns = [SpawnPoint(n, resolver.get(n, c).to_2d()) for n, c in frames if is_spawn_name(n)]
    models: list[ModelDescription] = []
    for m, c in parsed:
        pose = resolver.get(m.name, c)
        if is_spawn_name(m.name) and not m.has_collision:
            spawns.append(SpawnPoint(m.name, pose.to_2d()))
        else:
            models.append(ModelDescription(m.name, pose, m.static, tuple(m.links), m.source))
    return WorldDescription(
        name=node.attrib.get("name", "default"), models=tuple(models), lights=tuple(lights),
        spawn_points=tuple(spawns), physics=_physics(node, ctx), ground_material=_ground(parsed),
        unsupported=tuple(ctx.unsupported), source=source, sdf_version=version)


def _model_or_light(node: Node, ctx: ParseContext, lights: list[Light]) -> ParsedModel | None:
    """A <model>, or an <include> of a model or of a light (Gazebo's model://sun is a light)."""
    if node.tag == "model":
        return parse_model(node, ctx, WORLD)
    opened = open_include(node, ctx)
    root = opened[0]
    if root.tag != "model" and root.find("model") is None and root.find("light") is not None:
        light = root.find("light")
        assert light is not None
        pn = node.find("pose")
        lights.append(_light(light, ctx, read_pose(pn if pn is not None else light.find("pose")),
                             node.child_text("name")))
        return None
    return include_model(node, ctx, WORLD, opened)


def _unique(entries: dict[str, tuple[Pose3D, str, Node]], name: str, node: Node) -> None:
    if name in entries:
        raise FleetError(ErrorCode.INVALID_CONFIG, f"{node.where()}: duplicate name '{name}' in the world",
                         "models and frames of a world need unique names")


def _light(node: Node, ctx: ParseContext, pose: Pose3D, name: str | None = None) -> Light:
    name = name or named(node, "light")
    ctx.check_children(node, f"{WORLD}/light[{name}]", LIGHT_USED, LIGHT_IGNORED)
    kind = node.attrib.get("type", "point")
    if kind not in ("directional", "point", "spot"):
        raise FleetError(ErrorCode.INVALID_CONFIG, f"{node.where()}: light type must be directional, point or "
                         f"spot, got '{kind}'")
    d = node.find("diffuse")
    direction = child_vec(node, "direction", 3, ()) or None
    return Light(name, kind, pose, rgba(d) if d is not None else (1.0, 1.0, 1.0, 1.0),
                 child_bool(node, "cast_shadows", False),
                 (direction[0], direction[1], direction[2]) if direction else None)


def _physics(world: Node, ctx: ParseContext) -> PhysicsSettings:
    profiles = world.findall("physics")
    chosen = next((p for p in profiles if p.attrib.get("default", "").lower() in ("1", "true")),
                  profiles[0] if profiles else None)
    if len(profiles) > 1:
        ctx.note(f"{WORLD}/physics", "only the default physics profile is used")
    gravity = child_vec(world, "gravity", 3, ())
    if chosen is None:
        default = PhysicsSettings()
        g = gravity or default.gravity
        return PhysicsSettings(default.step_size, default.real_time_factor, (g[0], g[1], g[2]))
    ctx.check_children(chosen, f"{WORLD}/physics", PHYSICS_USED, PHYSICS_IGNORED)
    g = gravity or child_vec(chosen, "gravity", 3, (0.0, 0.0, -9.8))
    return PhysicsSettings(child_float(chosen, "max_step_size", 0.001, positive=True),
                           child_float(chosen, "real_time_factor", 1.0, positive=True), (g[0], g[1], g[2]))


def _ground(parsed: list[tuple[ParsedModel, Node]]) -> str | None:
    """The ground plane's texture (a file) or, failing that, its script material name."""
    for m, _ in parsed:
        if m.ground_textures:
            return m.ground_textures[0]
        for link in m.links:
            for v in link.visuals:
                if v.geometry.kind == "plane" and v.material:
                    return v.material
    return None

