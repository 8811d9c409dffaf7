"""WorldDescription → SDF 1.9 text that parse_sdf reads back to an equal description.

Numbers are written with Python's shortest round-trip repr, so a write → parse cycle is exact. Flattened
links named `inner::link` are written back as nested models (SDF 1.8+ forbids `::` in names). A model that
came from `<include>` of `model://name` is written as that include again when the model file still yields
the same links; otherwise it is written inline. Spawn points become world-level `<frame>`s.
"""

from __future__ import annotations

import os
from pathlib import Path
from xml.sax.saxutils import escape, quoteattr

from sim.errors import FleetError
from sim.sdf_context import ParseContext
from sim.sdf_model import include_model
from sim.sdf_paths import model_search_path
from sim.sdf_shapes import IMAGE_SUFFIXES
from sim.sdf_xml import Node
from sim.types import Box, Cylinder, Geometry, Light, Link, Mesh, ModelDescription, Plane, Pose3D, Sphere, Visual
from sim.types import WorldDescription as World

GAZEBO_MATERIALS = "file://media/materials/scripts/gazebo.material"


def _f(x: float) -> str:
    s = repr(float(x))
    return s[:-2] if s.endswith(".0") else s


def _v(vals: tuple[float, ...] | list[float]) -> str:
    return " ".join(_f(x) for x in vals)


def _pose(p: Pose3D, ind: str) -> list[str]:
    return [] if p == Pose3D() else [f"{ind}<pose>{_v((p.x, p.y, p.z, p.roll, p.pitch, p.yaw))}</pose>"]


class _Writer:
    def __init__(self, world: World, base_dir: Path | None, model_path: list[str] | None) -> None:
        self.world = world
        self.base_dir = base_dir
        self.search = model_search_path(model_path)
        self._included: dict[tuple[str, bool], tuple[Link, ...] | None] = {}

    def document(self, comment: str | None) -> str:
        w = self.world
        out = ['<?xml version="1.0" ?>']
        if comment:
            out.append(f"<!-- {escape(comment.replace('--', '- -'))} -->")
        out += ['<sdf version="1.9">', f"  <world name={quoteattr(w.name)}>"]
        ph = w.physics
        out += ['    <physics name="default_physics" default="true" type="ode">',
                f"      <max_step_size>{_f(ph.step_size)}</max_step_size>",
                f"      <real_time_factor>{_f(ph.real_time_factor)}</real_time_factor>",
                f"      <real_time_update_rate>{_f(ph.real_time_factor / ph.step_size)}</real_time_update_rate>",
                "    </physics>", f"    <gravity>{_v(ph.gravity)}</gravity>"]
        for light in w.lights:
            out += self._light(light)
        for sp in w.spawn_points:
            out += [f"    <frame name={quoteattr(sp.name)}>",
                    f"      <pose>{_v((sp.pose.x, sp.pose.y, 0.0, 0.0, 0.0, sp.pose.yaw))}</pose>", "    </frame>"]
        for m in w.models:
            out += self._include(m) if self._includable(m) else self._model(m, "    ")
        out += ["  </world>", "</sdf>", ""]
        return "\n".join(out)

    def _light(self, light: Light) -> list[str]:
        out = [f"    <light type={quoteattr(light.type)} name={quoteattr(light.name)}>",
               f"      <cast_shadows>{str(light.cast_shadows).lower()}</cast_shadows>"]
        out += _pose(light.pose, "      ")
        out.append(f"      <diffuse>{_v(light.diffuse)}</diffuse>")
        if light.direction is not None:
            out.append(f"      <direction>{_v(light.direction)}</direction>")
        return [*out, "    </light>"]

    def _includable(self, m: ModelDescription) -> bool:
        """True when `model://...` in m.source still yields exactly m's links."""
        if not m.source.startswith("model://"):
            return False
        key = (m.source, m.static)
        if key not in self._included:
            ctx = ParseContext(self.search)
            node = Node("include", {}, 0, "<writer>")
            node.children = [Node("uri", {}, 0, "<writer>", text=m.source),
                             Node("static", {}, 0, "<writer>", text=str(m.static).lower())]
            try:
                self._included[key] = tuple(include_model(node, ctx, "world").links)
            except FleetError:  # the model file is gone or broken: write this model inline
                self._included[key] = None
        return self._included[key] == m.links

    def _include(self, m: ModelDescription) -> list[str]:
        return ["    <include>", f"      <uri>{escape(m.source)}</uri>", f"      <name>{escape(m.name)}</name>",
                *_pose(m.pose, "      "), f"      <static>{str(m.static).lower()}</static>", "    </include>"]

    def _model(self, m: ModelDescription, ind: str) -> list[str]:
        out = [f"{ind}<model name={quoteattr(m.name)}>", f"{ind}  <static>{str(m.static).lower()}</static>"]
        out += _pose(m.pose, ind + "  ")
        out += self._links(list(m.links), m.static, ind + "  ")
        return [*out, f"{ind}</model>"]

    def _links(self, links: list[Link], static: bool, ind: str) -> list[str]:
        """Plain links, and `head::rest` links regrouped into nested models named `head` (in order)."""
        order: list[str | Link] = []
        nested: dict[str, list[Link]] = {}
        for lk in links:
            head, sep, rest = lk.name.partition("::")
            if not sep:
                order.append(lk)
                continue
            if head not in nested:
                nested[head] = []
                order.append(head)
            nested[head].append(Link(rest, lk.pose, lk.mass, lk.inertia, lk.collisions, lk.visuals))
        out: list[str] = []
        for item in order:
            if isinstance(item, Link):
                out += self._link(item, static, ind)
            else:
                out += [f"{ind}<model name={quoteattr(item)}>", f"{ind}  <static>{str(static).lower()}</static>",
                        *self._links(nested[item], static, ind + "  "), f"{ind}</model>"]
        return out

    def _link(self, lk: Link, static: bool, ind: str) -> list[str]:
        out = [f"{ind}<link name={quoteattr(lk.name)}>", *_pose(lk.pose, ind + "  ")]
        if not static or lk.mass > 0 or any(lk.inertia):
            keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
            out += [f"{ind}  <inertial>", f"{ind}    <mass>{_f(lk.mass)}</mass>", f"{ind}    <inertia>",
                    *(f"{ind}      <{k}>{_f(v)}</{k}>" for k, v in zip(keys, lk.inertia, strict=True)),
                    f"{ind}    </inertia>", f"{ind}  </inertial>"]
        for c in lk.collisions:
            out += [f"{ind}  <collision name={quoteattr(c.name)}>", *_pose(c.pose, ind + "    "),
                    *self._geometry(c.geometry, ind + "    ")]
            if c.friction is not None:
                out.append(f"{ind}    <surface><friction><ode><mu>{_f(c.friction)}</mu></ode></friction></surface>")
            out.append(f"{ind}  </collision>")
        for v in lk.visuals:
            out += [f"{ind}  <visual name={quoteattr(v.name)}>", *_pose(v.pose, ind + "    "),
                    *self._geometry(v.geometry, ind + "    "), *self._material(v, ind + "    "), f"{ind}  </visual>"]
        return [*out, f"{ind}</link>"]

    def _material(self, v: Visual, ind: str) -> list[str]:
        out = [f"{ind}<material>"]
        if v.material:
            out += [f"{ind}  <script>", f"{ind}    <uri>{GAZEBO_MATERIALS}</uri>",
                    f"{ind}    <name>{escape(v.material)}</name>", f"{ind}  </script>"]
        out += [f"{ind}  <ambient>{_v(v.rgba)}</ambient>", f"{ind}  <diffuse>{_v(v.rgba)}</diffuse>"]
        tex = self.world.ground_material
        if v.geometry.kind == "plane" and tex and Path(tex).suffix.lower() in IMAGE_SUFFIXES:
            rel = os.path.relpath(tex, self.base_dir) if self.base_dir is not None else tex
            out += [f"{ind}  <pbr>", f"{ind}    <metal>", f"{ind}      <albedo_map>{escape(rel)}</albedo_map>",
                    f"{ind}    </metal>", f"{ind}  </pbr>"]
        return [*out, f"{ind}</material>"]


    def _geometry(self, g: Geometry, ind: str) -> list[str]:
        i2 = ind + "  "
        if isinstance(g, Box):
            body = f"<box><size>{_v(g.size)}</size></box>"
        elif isinstance(g, Cylinder):
            body = f"<cylinder><radius>{_f(g.radius)}</radius><length>{_f(g.length)}</length></cylinder>"
        elif isinstance(g, Sphere):
            body = f"<sphere><radius>{_f(g.radius)}</radius></sphere>"
        elif isinstance(g, Plane):
            body = f"<plane><normal>{_v(g.normal)}</normal><size>{_v(g.size)}</size></plane>"
        else:
            assert isinstance(g, Mesh)
            body = f"<mesh><uri>{escape(self._mesh_uri(g))}</uri><scale>{_v(g.scale)}</scale></mesh>"
        return [f"{ind}<geometry>", i2 + body, f"{ind}</geometry>"]

    def _mesh_uri(self, g: Mesh) -> str:
        """The URI as read, unless it is relative and would not find the file from the new location."""
        if g.uri.startswith(("model://", "file://", "http://", "https://")) or Path(g.uri).is_absolute():
            return g.uri
        if self.base_dir is None or (self.base_dir / g.uri).resolve() == Path(g.path):
            return g.uri
        return os.path.relpath(g.path, self.base_dir)


def write_sdf(description: World, *, base_dir: str | Path | None = None, model_path: list[str] | None = None,
              comment: str | None = None) -> str:
    """SDF 1.9 text of `description`; texture paths are written relative to `base_dir` when given."""
    return _Writer(description, Path(base_dir) if base_dir else None, model_path).document(comment)


def save_sdf(description: World, path: str | Path, *, model_path: list[str] | None = None,
             comment: str | None = None) -> None:
    p = Path(path)
    text = write_sdf(description, base_dir=p.resolve().parent, model_path=model_path, comment=comment)
    p.write_text(text, encoding="utf-8")
