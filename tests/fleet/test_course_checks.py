"""Course artefact checks: the shipped world and robot pass; mutated copies fail exactly the mutated items."""

from __future__ import annotations

import subprocess
import sys
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path

import pytest

from fleet.grading import check_robot, check_world

ROOT = Path(__file__).resolve().parents[2]
WORLD = ROOT / "configs/worlds/robot_arena.world"
ROBOT = ROOT / "configs/robots/diffbot.urdf"


def test_shipped_world_and_robot_pass_every_item():
    w, r = check_world(WORLD), check_robot(ROBOT)
    assert w.failed_keys() == [] and w.earned == w.total == 15
    assert r.failed_keys() == [] and r.earned == r.total == 25


def mutate(src: Path, tmp: Path, fn: Callable[[ET.Element], None]) -> Path:
    tree = ET.parse(src)
    fn(tree.getroot())
    out = tmp / src.name
    tree.write(out)
    # keep relative assets (textures, meshes) resolvable from the copy
    for sub in ("textures",):
        if (src.parent / sub).exists() and not (tmp / sub).exists():
            (tmp / sub).symlink_to(src.parent / sub)
    return out


def _drop(root: ET.Element, path: str, keep: int = 0) -> None:
    parent_of = {c: p for p in root.iter() for c in p}
    for el in root.findall(path)[keep:]:
        parent_of[el].remove(el)


def _drop_all(root: ET.Element, paths: list[str]) -> None:
    for path in paths:
        _drop(root, path)


WORLD_MUTATIONS = {
    "lights": lambda r: _drop(r, ".//world/light", keep=1),
    "shape_variety": lambda r: _drop_all(r, [f".//model[@name='{m}']" for m in ("sphere_ball", "sphere_boulder")]),
    "spawn_point": lambda r: _drop(r, ".//world/frame"),
    "ground_textured": lambda r: _drop(r, ".//model[@name='ground_plane']//material"),
}


@pytest.mark.parametrize("item", sorted(WORLD_MUTATIONS))
def test_mutated_world_fails_exactly_the_mutated_item(item: str, tmp_path: Path):
    report = check_world(mutate(WORLD, tmp_path, WORLD_MUTATIONS[item]))
    assert report.failed_keys() == [item]


def _set(path: str, attr: str | None, value: str) -> Callable[[ET.Element], None]:
    def fn(root: ET.Element) -> None:
        els = root.findall(path)
        assert els, path
        for el in els:
            if attr:
                el.set(attr, value)
            else:
                el.text = value

    return fn


ROBOT_MUTATIONS = {
    "chassis": _set(".//link[@name='chassis_link']//box", "size", "0.6 0.4 0.2"),
    "lidar": _set(".//sensor[@type='ray']//samples", None, "180"),
    "camera": _set(".//sensor[@type='camera']//width", None, "320"),
    "imu": _set(".//sensor[@type='imu']/update_rate", None, "50"),
    "mass": _set(".//link[@name='chassis_link']/inertial/mass", "value", "6.0"),
    "collision_matches_visual": _set(".//link[@name='caster_link']/collision//sphere", "radius", "0.06"),
    "inertials": lambda r: _drop(r, ".//link[@name='imu_link']/inertial"),
    "wheel_separation": _set(".//joint[@name='right_wheel_joint']/origin", "xyz", "0 -0.3 0.1"),
}


@pytest.mark.parametrize("item", sorted(ROBOT_MUTATIONS))
def test_mutated_robot_fails_exactly_the_mutated_item(item: str, tmp_path: Path):
    report = check_robot(mutate(ROBOT, tmp_path, ROBOT_MUTATIONS[item]))
    assert report.failed_keys() == [item]


def test_cli_exit_codes_and_line_per_item(tmp_path: Path):
    ok = subprocess.run([sys.executable, "-m", "fleetnav.cli", "check", "robot", str(ROBOT), "--json"],
                        capture_output=True, text=True, cwd=ROOT)
    assert ok.returncode == 0 and '"earned": 25' in ok.stdout
    bad = mutate(ROBOT, tmp_path, ROBOT_MUTATIONS["camera"])
    fail = subprocess.run([sys.executable, "-m", "fleetnav.cli", "check", "robot", str(bad)],
                          capture_output=True, text=True, cwd=ROOT)
    assert fail.returncode == 1 and "FAIL" in fail.stdout
    broken = tmp_path / "broken.urdf"
    broken.write_text("<robot name='x'><link name='a'></robot>")
    err = subprocess.run([sys.executable, "-m", "fleetnav.cli", "check", "robot", str(broken)],
                         capture_output=True, text=True, cwd=ROOT)
    assert err.returncode == 2 and "broken.urdf:1" in err.stderr
