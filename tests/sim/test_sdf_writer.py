"""write_sdf → parse_sdf gives back an equal description (hand-written Gazebo world, generated worlds)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from sim.sdf_parser import parse_sdf, parse_sdf_string
from sim.sdf_writer import save_sdf, write_sdf
from sim.types import Mesh, WorldDescription
from sim.worldgen import cluttered_arena, warehouse
from tests.sim.test_sdf_parser import write_world_16


def _same(a: WorldDescription, b: WorldDescription) -> None:
    a, b = replace(a, source=""), replace(b, source="")
    for ma, mb in zip(a.models, b.models, strict=True):
        assert ma == mb, ma.name
    assert a == b


def test_gazebo_world_round_trips(tmp_path: Path) -> None:
    path, models = write_world_16(tmp_path)
    original = parse_sdf(path, model_path=[str(models)])
    out = tmp_path / "again.world"
    save_sdf(original, out, model_path=[str(models)])
    again = parse_sdf(out, model_path=[str(models)])
    # Unsupported elements were not kept, so they are not written back; the file is SDF 1.9 now.
    _same(replace(original, unsupported=(), sdf_version="1.9"), again)
    text = out.read_text()
    assert "::" not in text  # nested links are written back as nested models
    assert text.count("<uri>model://crate</uri>") == 2 and "<frame name=\"spawn_robot\">" in text


def test_relative_mesh_uris_still_resolve_when_saved_elsewhere(tmp_path: Path) -> None:
    path, models = write_world_16(tmp_path)
    original = parse_sdf(path, model_path=[str(models)])
    out = tmp_path / "saved" / "again.world"
    out.parent.mkdir()
    save_sdf(original, out, model_path=[str(models)])
    again = parse_sdf(out, model_path=[str(models)])
    a, b = (w.models[2].links[0].collisions[0].geometry for w in (original, again))
    assert "../meshes/cube.obj" in out.read_text()
    assert isinstance(a, Mesh) and isinstance(b, Mesh) and a.path == b.path and a.scale == b.scale


def test_generated_worlds_round_trip_exactly() -> None:
    for world in (cluttered_arena(seed=3, difficulty=4), warehouse(size=24.0)):
        _same(world, parse_sdf_string(write_sdf(world)))


def test_included_shelves_are_written_as_includes() -> None:
    text = write_sdf(warehouse(size=24.0))
    n = sum(1 for m in warehouse(size=24.0).models if m.source == "model://warehouse_shelf")
    assert n > 10 and text.count("<uri>model://warehouse_shelf</uri>") == n


def test_changed_included_model_is_written_inline() -> None:
    w = warehouse(size=24.0)
    shelf = next(m for m in w.models if m.source)
    moved = replace(shelf, links=(replace(shelf.links[0], mass=3.0),))
    w2 = replace(w, models=(w.models[0], moved))  # the ground plane and the changed shelf
    text = write_sdf(w2)
    assert "<include>" not in text and f'<model name="{shelf.name}">' in text
    # Written inline, the model no longer comes from the include: its source is dropped, nothing else.
    _same(replace(w2, models=(w.models[0], replace(moved, source=""))), parse_sdf_string(text))
