"""SDF <geometry>, <material> and <surface> elements → sim.types values.

Meshes PyBullet can load (OBJ, STL) are resolved to a file on disk; other formats and shapes fleetnav has no
type for are listed as unsupported and dropped (the caller drops the collision/visual that held them).
"""

from __future__ import annotations

from pathlib import Path

from sim.errors import ErrorCode, FleetError
from sim.sdf_context import ParseContext, base_dir
from sim.sdf_paths import resolve_uri
from sim.sdf_xml import Node, child_float, child_vec, floats, rgba
from sim.types import Box, Cylinder, Geometry, Mesh, Plane, Sphere

MESH_FORMATS = (".obj", ".stl")
DEFAULT_RGBA = (0.7, 0.7, 0.7, 1.0)

# Diffuse colours of the common Gazebo script materials (media/materials/scripts/gazebo.material),
# used when a file names a script material without its own <diffuse>/<ambient>.
GAZEBO_COLOURS: dict[str, tuple[float, float, float, float]] = {
    "Gazebo/Grey": (0.7, 0.7, 0.7, 1.0), "Gazebo/DarkGrey": (0.175, 0.175, 0.175, 1.0),
    "Gazebo/LightGrey": (0.85, 0.85, 0.85, 1.0), "Gazebo/White": (1.0, 1.0, 1.0, 1.0),
    "Gazebo/Black": (0.0, 0.0, 0.0, 1.0), "Gazebo/FlatBlack": (0.1, 0.1, 0.1, 1.0),
    "Gazebo/Red": (1.0, 0.0, 0.0, 1.0), "Gazebo/Green": (0.0, 1.0, 0.0, 1.0),
    "Gazebo/Blue": (0.0, 0.0, 1.0, 1.0), "Gazebo/Yellow": (1.0, 1.0, 0.0, 1.0),
    "Gazebo/Orange": (1.0, 0.5088, 0.0468, 1.0), "Gazebo/Purple": (1.0, 0.0, 1.0, 1.0),
    "Gazebo/Turquoise": (0.0, 1.0, 1.0, 1.0), "Gazebo/Indigo": (0.33, 0.0, 0.5, 1.0),
    "Gazebo/Gold": (0.8, 0.64, 0.0, 1.0), "Gazebo/Wood": (0.56, 0.38, 0.22, 1.0),
    "Gazebo/WoodFloor": (0.6, 0.45, 0.3, 1.0), "Gazebo/Grass": (0.3, 0.55, 0.2, 1.0),
    "Gazebo/Bricks": (0.6, 0.3, 0.2, 1.0), "Gazebo/CeilingTiled": (0.8, 0.8, 0.8, 1.0),
}

_UNSUPPORTED_SHAPES = {"capsule", "ellipsoid", "heightmap", "polyline", "image"}


def parse_geometry(node: Node, path: str, ctx: ParseContext) -> Geometry | None:
    """The first shape inside <geometry>; None (and an unsupported entry) for shapes fleetnav cannot use."""
    for g in node.children:
        p = f"{path}/geometry/{g.tag}"
        if g.tag == "box":
            size = child_vec(g, "size", 3, (1.0, 1.0, 1.0))
            if min(size) <= 0:
                raise FleetError(ErrorCode.INVALID_CONFIG, f"{g.where()}: <box><size> must be positive, got {size}")
            return Box((size[0], size[1], size[2]))
        if g.tag == "cylinder":
            return Cylinder(child_float(g, "radius", 1.0, positive=True), child_float(g, "length", 1.0, positive=True))
        if g.tag == "sphere":
            return Sphere(child_float(g, "radius", 1.0, positive=True))
        if g.tag == "plane":
            n = child_vec(g, "normal", 3, (0.0, 0.0, 1.0))
            s = child_vec(g, "size", 2, (100.0, 100.0))
            if max(abs(x) for x in n) == 0 or min(s) <= 0:
                raise FleetError(ErrorCode.INVALID_CONFIG, f"{g.where()}: <plane> needs a non-zero <normal> "
                                 f"and a positive <size>, got {n} and {s}")
            return Plane((n[0], n[1], n[2]), (s[0], s[1]))
        if g.tag == "mesh":
            return _mesh(g, p, ctx)
        if g.tag in _UNSUPPORTED_SHAPES:
            ctx.note(p)
            return None
        if g.tag != "empty":
            ctx.note(p, "unknown geometry")
    return None


def _mesh(g: Node, path: str, ctx: ParseContext) -> Mesh | None:
    uri_node = g.find("uri")
    if uri_node is None or not uri_node.text.strip():
        raise FleetError(ErrorCode.INVALID_CONFIG, f"{g.where()}: <mesh> needs a <uri>")
    uri = uri_node.text.strip()
    if g.find("submesh") is not None:
        ctx.note(f"{path}/submesh", "the whole mesh is used")
    ext = Path(uri.split("?")[0]).suffix.lower()
    if ext not in MESH_FORMATS:
        ctx.note(path, f"'{uri}': PyBullet loads only OBJ and STL meshes")
        return None
    resolved = resolve_uri(uri, base_dir(g), ctx.search)
    if resolved is None:
        if uri.startswith(("http://", "https://")):
            ctx.note(path, f"'{uri}' is not in the local Fuel cache (no downloads)")
            return None
        where = ", ".join(str(d) for d in ctx.search)
        raise FleetError(ErrorCode.NOT_FOUND, f"{uri_node.where()}: mesh '{uri}' not found",
                         f"relative URIs are resolved against {base_dir(g)}; model:// against {where}")
    scale = child_vec(g, "scale", 3, (1.0, 1.0, 1.0))
    return Mesh(uri, str(resolved), (scale[0], scale[1], scale[2]))


def parse_material(node: Node | None, path: str, ctx: ParseContext) -> tuple[
        tuple[float, float, float, float], str | None, str | None]:
    """(rgba, script material name, resolved albedo texture path) of a <material>."""
    if node is None:
        return DEFAULT_RGBA, None, None
    script = node.find("script")
    name = script.child_text("name") if script is not None else None
    colour = DEFAULT_RGBA
    if (d := node.find("diffuse")) is not None:
        colour = rgba(d)
    elif (a := node.find("ambient")) is not None:
        colour = rgba(a)
    elif name in GAZEBO_COLOURS:
        colour = GAZEBO_COLOURS[name]
    texture = None
    pbr = node.find("pbr")
    for wf in pbr.children if pbr is not None else []:
        amap = wf.find("albedo_map")
        if amap is not None and amap.text.strip():
            found = resolve_uri(amap.text.strip(), base_dir(amap), ctx.search)
            if found is None:
                ctx.note(f"{path}/material/pbr/{wf.tag}/albedo_map", f"texture '{amap.text.strip()}' not found")
            else:
                texture = str(found)
    return colour, name or None, texture


def parse_friction(surface: Node | None) -> float | None:
    """Coulomb friction from <surface><friction>: ODE `mu`, else Bullet `friction`."""
    fr = surface.find("friction") if surface is not None else None
    if fr is None:
        return None
    for engine, tag in (("ode", "mu"), ("bullet", "friction")):
        e = fr.find(engine)
        c = e.find(tag) if e is not None else None
        if c is not None:
            v = floats(c, 1)[0]
            if v < 0:
                raise FleetError(ErrorCode.INVALID_CONFIG, f"{c.where()}: friction must be ≥ 0, got {v}")
            return v
    return None
