"""Course artefact checks: the shipped world and robot pass; mutated copies fail exactly the mutated items."""

from __future__ import annotations

import subprocess
import sys
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path

import pytest

from fleet.grading import RubricReport, check_robot, check_world

ROOT = Path(__file__).resolve().parents[2]
WORLD = ROOT / "configs/worlds/robot_arena.world"
ROBOT = ROOT / "configs/robots/diffbot.urdf"


def test_shipped_world_and_robot_pass_every_item():
    w, r = check_world(WORLD), check_robot(ROBOT)
    assert w.failed_keys() == [] and w.earned == w.total == 15
    assert r.failed_keys() == [] and r.earned == r.total == 45  # Robot Model 25 + Gazebo Plugins 20
    assert w.title.endswith("(robot_arena.world)") and r.title.endswith("(diffbot.urdf)")  # names the graded file


def test_course_robot_written_from_the_assignment_passes():
    report = check_robot(ROOT / "configs/robots/course_robot.urdf")
    assert report.failed_keys() == [] and report.earned == 45


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
    # Only the four outer walls and the free-standing obstacles remain: the path is nearly straight.
    "maze": lambda r: _drop_all(r, [f".//model[@name='{m}']" for m in ("barrier_south", "barrier_north",
                                                                       "stub_south", "stub_north", "box_long")]),
    "obstacle_count": lambda r: _drop_all(r, [f".//model[@name='{m}']" for m in ("box_crate", "box_diamond",
                                                                                 "cylinder_pillar", "box_long")]),
}


def _fence_goal(root: ET.Element) -> None:
    """Four walls round the goal marker at (5, 5): the goal is unreachable, the path ratio meaningless."""
    world = root.find("world")
    assert world is not None
    for k, (x, y, sx, sy) in enumerate([(5, 4.2, 1.8, 0.2), (5, 5.8, 1.8, 0.2), (4.2, 5, 0.2, 1.8),
                                        (5.8, 5, 0.2, 1.8)]):
        model = ET.SubElement(world, "model", name=f"fence_{k}")
        ET.SubElement(model, "static").text = "true"
        ET.SubElement(model, "pose").text = f"{x} {y} 0.5 0 0 0"
        geom = ET.SubElement(ET.SubElement(ET.SubElement(model, "link", name="link"), "collision", name="c"),
                             "geometry")
        ET.SubElement(ET.SubElement(geom, "box"), "size").text = f"{sx} {sy} 1"


def test_unreachable_goal_fails_the_maze_item(tmp_path: Path):
    report = check_world(mutate(WORLD, tmp_path, _fence_goal))
    assert report.failed_keys() == ["maze"]
    assert "goal unreachable" in next(i.measured for i in report.items if i.key == "maze")


def test_obstacles_are_counted_per_collision_geometry(tmp_path: Path):
    """Five obstacles written as links of one model count as five; the maze still stands."""
    def merge(root: ET.Element) -> None:
        _drop_all(root, [f".//model[@name='{m}']" for m in ("box_crate", "cylinder_barrel", "sphere_ball",
                                                              "box_diamond", "cylinder_pillar", "sphere_boulder")])
        world = root.find("world")
        assert world is not None
        model = ET.SubElement(world, "model", name="clutter")
        ET.SubElement(model, "static").text = "true"
        for k, (x, shape) in enumerate([(-3, "box"), (-1, "cylinder"), (1, "sphere"), (3, "box"), (0, "sphere")]):
            link = ET.SubElement(model, "link", name=f"part_{k}")
            ET.SubElement(link, "pose").text = f"{x} -3.8 0.3 0 0 0"
            g = ET.SubElement(ET.SubElement(link, "collision", name="c"), "geometry")
            el = ET.SubElement(g, shape)
            if shape == "box":
                ET.SubElement(el, "size").text = "0.4 0.4 0.6"
            else:
                ET.SubElement(el, "radius").text = "0.25"
                if shape == "cylinder":
                    ET.SubElement(el, "length").text = "0.6"

    def count(report: RubricReport) -> int:
        return int(next(i.measured for i in report.items if i.key == "obstacle_count").split()[0])

    report = check_world(mutate(WORLD, tmp_path, merge))
    assert report.failed_keys() == []
    assert count(report) == count(check_world(WORLD)) - 6 + 5  # six models out, one model of five links in


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


def _both(*fns: Callable[[ET.Element], None]) -> Callable[[ET.Element], None]:
    def fn(root: ET.Element) -> None:
        for f in fns:
            f(root)

    return fn


ROBOT_MUTATIONS = {
    "chassis": _set(".//link[@name='chassis_link']//box", "size", "0.6 0.4 0.2"),
    "lidar": _set(".//sensor[@type='ray']//samples", None, "180"),
    "camera": _set(".//sensor[@type='camera']//width", None, "320"),
    "imu": _set(".//sensor[@type='imu']/update_rate", None, "50"),
    "mass": _set(".//link[@name='chassis_link']/inertial/mass", "value", "6.0"),
    "collision_matches_visual": _set(".//link[@name='caster_link']/visual//sphere", "radius", "0.06"),
    "inertials": lambda r: _drop(r, ".//link[@name='imu_link']/inertial"),
    # Wheels and plugin moved together: the plugin stays consistent, the separation is wrong.
    "wheel_separation": _both(_set(".//joint[@name='right_wheel_joint']/origin", "xyz", "0 -0.3 0.1"),
                              _set(".//plugin[@name='diff_drive']/wheel_separation", None, "0.5")),
    # Wheels sunk 5 cm into the floor: the caster (and chassis) float above the ground they stand on.
    "ground_contact": _set(".//joint[@name='left_wheel_joint']/origin", "xyz", "0 0.2 0.05"),
    # A valid tensor copied from elsewhere: positive definite, triangle inequality holds, far from a 3.25 kg box.
    "inertia_geometry": _both(*(_set(".//link[@name='chassis_link']/inertial/inertia", k, "1")
                                for k in ("ixx", "iyy", "izz"))),
    "diff_drive_plugin": _set(".//plugin[@name='diff_drive']/wheel_diameter", None, "0.3"),
    "sensor_plugins": lambda r: _drop(r, ".//sensor[@type='camera']/plugin"),
}


def test_a_robot_without_plugins_fails_both_plugin_items(tmp_path: Path):
    report = check_robot(mutate(ROBOT, tmp_path, lambda r: _drop(r, ".//plugin")))
    assert report.failed_keys() == ["diff_drive_plugin", "sensor_plugins"]
    assert report.earned == 25


def test_a_non_physical_tensor_fails_inertials_only(tmp_path: Path):
    # I_small + I_mid < I_large: no rigid body has it (it is not also judged against the geometry).
    def bad(root: ET.Element) -> None:
        el = root.find(".//link[@name='chassis_link']/inertial/inertia")
        assert el is not None
        for k, v in (("ixx", "0.01"), ("iyy", "0.01"), ("izz", "0.5")):
            el.set(k, v)

    assert check_robot(mutate(ROBOT, tmp_path, bad)).failed_keys() == ["inertials"]


@pytest.mark.parametrize("item", sorted(ROBOT_MUTATIONS))
def test_mutated_robot_fails_exactly_the_mutated_item(item: str, tmp_path: Path):
    report = check_robot(mutate(ROBOT, tmp_path, ROBOT_MUTATIONS[item]))
    assert report.failed_keys() == [item]


def test_cli_exit_codes_and_line_per_item(tmp_path: Path):
    ok = subprocess.run([sys.executable, "-m", "fleetnav.cli", "check", "robot", str(ROBOT), "--json"],
                        capture_output=True, text=True, cwd=ROOT)
    assert ok.returncode == 0 and '"earned": 45' in ok.stdout
    bad = mutate(ROBOT, tmp_path, ROBOT_MUTATIONS["camera"])
    fail = subprocess.run([sys.executable, "-m", "fleetnav.cli", "check", "robot", str(bad)],
                          capture_output=True, text=True, cwd=ROOT)
    assert fail.returncode == 1 and "FAIL" in fail.stdout
    broken = tmp_path / "broken.urdf"
    broken.write_text("<robot name='x'><link name='a'></robot>")
    err = subprocess.run([sys.executable, "-m", "fleetnav.cli", "check", "robot", str(broken)],
                         capture_output=True, text=True, cwd=ROOT)
    assert err.returncode == 2 and "broken.urdf:1" in err.stderr
