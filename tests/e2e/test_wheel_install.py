"""The built wheel works outside the checkout: shipped robots, worlds, models and missions are found through
importlib.resources from any folder, a user's mission resolves its URDF robot relative to itself, and a bad
mission is a setup error (exit 2, JUnit <error>) rather than a failed assertion (exit 1).

Offline and quick: the wheel is built without build isolation and installed with --no-deps into a fresh venv
that borrows the dev environment's site-packages for the dependencies (a .pth line, which does not activate
the dev environment's editable install of fleetnav)."""

from __future__ import annotations

import json
import os
import shutil
import site
import subprocess
import sys
from pathlib import Path
from xml.etree import ElementTree as ET

import pytest

REPO = Path(__file__).resolve().parents[2]
COURSE_URDF = REPO / "configs" / "robots" / "course_robot.urdf"

USER_MISSION = """\
name: my_robot_mission
world: robot_arena
seed: 1
time_limit: 12
physics: {physics_hz: 100, control_hz: 10, fidelity: kinematic}
robots:
  - {name: r1, model: robots/my_robot.urdf, pose: {x: -5.0, y: -5.0, yaw: 0.0}}
tasks:
  - {id: hop, robot: r1, type: go_to, params: {goal: {x: -3.5, y: -5.0}}}
assertions:
  - {name: arrives, type: reach_goal, robot: r1, task: hop, tolerance: 0.3, within: 12}
"""

BAD_MISSION = USER_MISSION.replace("name: my_robot_mission", "name: bad_mission").replace(
    "robots/my_robot.urdf", "robots/missing.urdf")


def _run(cmd: list[str], cwd: Path, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    return subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope="module")
def venv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    tmp = tmp_path_factory.mktemp("wheel")
    src = tmp / "src"  # build from a copy: the build writes build/ and *.egg-info next to the sources
    shutil.copytree(REPO, src, ignore=shutil.ignore_patterns(".venv", ".git", "build", "dist", "runs", "*.egg-info",
                                                            "__pycache__", ".mypy_cache", ".ruff_cache", "tests"))
    built = _run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation", "-w",
                  str(tmp / "dist"), str(src)], tmp)
    assert built.returncode == 0, built.stderr
    wheel = next((tmp / "dist").glob("fleetnav-*.whl"))
    env_dir = tmp / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(env_dir)], check=True)
    py = env_dir / "bin" / "python"
    own = Path(_run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"], tmp).stdout.strip())
    (own / "zz_dev_deps.pth").write_text("\n".join(site.getsitepackages()) + "\n")  # dependencies only
    installed = _run([sys.executable, "-m", "pip", "--python", str(py), "install", "-q", "--no-deps", "--no-index",
                      str(wheel)], tmp)
    assert installed.returncode == 0, installed.stderr
    return env_dir


def test_shipped_mission_runs_from_any_folder(venv: Path, tmp_path: Path):
    py = venv / "bin" / "python"
    where = _run([str(py), "-c", "import sim; from sim.resources import shipped; print(sim.__file__); "
                  "print(shipped('missions', 'arena_navigation.yaml'))"], tmp_path)
    module, mission = where.stdout.split()
    # The wheel's code and data, not the checkout's.
    assert Path(module).is_relative_to(venv) and Path(mission).is_relative_to(venv), where.stdout
    run = _run([str(venv / "bin" / "fleetnav"), "run", mission, "--no-record", "--out", "out"], tmp_path)
    assert run.returncode == 0, run.stdout + run.stderr
    report = json.loads((tmp_path / "out" / "arena_navigation" / "report.json").read_text())
    assert report["passed"] and report["world"] == "robot_arena"


def test_user_urdf_mission_and_setup_errors_under_pytest_missions(venv: Path, tmp_path: Path):
    (tmp_path / "robots").mkdir()
    shutil.copy(COURSE_URDF, tmp_path / "robots" / "my_robot.urdf")
    (tmp_path / "missions").mkdir()
    (tmp_path / "missions" / "robots").symlink_to(tmp_path / "robots")  # relative to the mission file
    (tmp_path / "missions" / "mine.yaml").write_text(USER_MISSION)
    (tmp_path / "missions" / "bad.yaml").write_text(BAD_MISSION)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    res = _run([str(venv / "bin" / "python"), "-m", "pytest", "-p", "no:cacheprovider", "--missions",
                str(tmp_path / "missions"), "--missions-no-record", "--junitxml", str(tmp_path / "j.xml"),
                "--rootdir", str(elsewhere)], elsewhere)
    assert res.returncode == 1, res.stdout + res.stderr  # one error: pytest's exit code for "not all passed"
    suite = ET.parse(tmp_path / "j.xml").getroot().find("testsuite")
    assert suite is not None
    assert (suite.get("tests"), suite.get("errors"), suite.get("failures")) == ("2", "1", "0"), res.stdout
    assert "robots/missing.urdf" in res.stdout and "does not exist" in res.stdout

    bad = _run([str(venv / "bin" / "fleetnav"), "run", str(tmp_path / "missions" / "bad.yaml"), "--no-record",
                "--out", "out"], elsewhere)
    assert bad.returncode == 2, bad.stdout + bad.stderr
    junit = (elsewhere / "out" / "junit.xml").read_text()
    assert "<error" in junit and "<failure" not in junit
