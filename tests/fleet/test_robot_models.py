"""Robot models through the service: a name, a URDF file or URDF text all spawn; a file is found relative to
the file that names it; unknown names list the known ones; load warnings reach the caller."""

from __future__ import annotations

from pathlib import Path

import pytest

from fleet.config import FleetConfig
from fleet.paths import robot_file, robot_model
from fleet.service import FleetService
from sim import Pose2D
from sim.errors import FleetError
from sim.resources import shipped


def test_spawn_by_name_file_and_text_with_warnings():
    svc = FleetService(FleetConfig(world="empty"))
    try:
        text = shipped("robots", "course_robot.urdf").read_text()
        svc.spawn_robot("a", Pose2D(0.0, 0.0, 0.0), model="course_robot")
        svc.spawn_robot("b", Pose2D(2.0, 0.0, 0.0), model=text)
        svc.spawn_robot("c", Pose2D(4.0, 0.0, 0.0), model=str(shipped("robots", "diffbot.urdf")))
        assert svc.world.robot_spec("a").lidar_height == pytest.approx(0.57)
        assert svc.world.robot_spec("b") == svc.world.robot_spec("a")  # the same description, text or file
        assert any("max linear speed" in w for w in svc.robot_model("course_robot").warnings)
        assert svc.robot_model("diffbot").warnings == ()  # YAML states everything
    finally:
        svc.close()


def test_robot_files_resolve_relative_to_the_referencing_file(tmp_path: Path):
    (tmp_path / "robots").mkdir()
    target = tmp_path / "robots" / "mine.urdf"
    target.write_text(shipped("robots", "course_robot.urdf").read_text())
    assert robot_file("robots/mine.urdf", tmp_path) == target.resolve()
    assert robot_model("robots/mine.urdf", tmp_path).spec.wheels.separation == 0.4
    with pytest.raises(FleetError, match=r"does not exist \(relative to"):
        robot_file("robots/other.urdf", tmp_path)
    with pytest.raises(FleetError) as err:
        robot_file("nobot")
    assert "course_robot" in err.value.hint and "diffbot" in err.value.hint


def test_challenge_robot_is_relative_to_the_challenge_file(tmp_path: Path, monkeypatch):
    from fleet.grading.challenge import load_challenge

    (tmp_path / "robots").mkdir()
    (tmp_path / "robots" / "mine.urdf").write_text(shipped("robots", "course_robot.urdf").read_text())
    (tmp_path / "c.yaml").write_text("name: c1\nworld: robot_arena\nstart: spawn_start\ngoal: goal_marker\n"
                                     "time_limit: 5\nrobot: robots/mine.urdf\n")
    monkeypatch.chdir(tmp_path.parent)  # not the challenge's folder: the file's folder decides
    assert load_challenge(tmp_path / "c.yaml").robot == str((tmp_path / "robots" / "mine.urdf").resolve())
    (tmp_path / "c.yaml").write_text((tmp_path / "c.yaml").read_text().replace("mine.urdf", "gone.urdf"))
    with pytest.raises(FleetError, match=r"robots/gone\.urdf' does not exist"):
        load_challenge(tmp_path / "c.yaml")


def test_package_path_from_the_config(monkeypatch):
    monkeypatch.delenv("FLEETNAV_PACKAGE_PATH", raising=False)
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    data = Path(__file__).resolve().parents[1] / "sim" / "data"
    jackal = str(data / "robots" / "jackal_like.urdf")
    with pytest.raises(FleetError, match="cannot find package 'jackal_like_description'"):
        robot_model(jackal)
    svc = FleetService(FleetConfig(world="empty", package_path=[str(data / "packages")]))
    try:
        assert svc.robot_model(jackal).spec.wheels.left_joints == ("front_left_wheel", "rear_left_wheel")
    finally:
        svc.close()
