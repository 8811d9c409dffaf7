"""Mission, challenge and grading tools: background jobs in their own worlds, reports checked for verdicts."""

from __future__ import annotations

from pathlib import Path

import pytest

from fleet import FleetService
from fleet.paths import CONFIGS
from tests.mcp_server.helpers import err, ok

pytestmark = pytest.mark.anyio

MISSION = """name: hop
world: empty
seed: 0
time_limit: 6
robots:
  - {name: r1, pose: {x: 0.0, y: 0.0, yaw: 0.0}}
tasks:
  - {id: hop, robot: r1, type: go_to, params: {goal: {x: 0.6, y: 0.0}}}
recording: {enabled: false}
assertions:
  - {name: hops, type: reach_goal, robot: r1, task: hop, tolerance: 0.2, within: 6}
"""

CHALLENGE = """name: short_hop
world: empty
start: {x: 0.0, y: 0.0}
goal: {x: 1.5, y: 0.0}
success_radius: 0.3
time_limit: 20
runs: 1
"""


async def test_mission_runs_in_the_background_and_reports(client, service: FleetService, workspace: Path) -> None:
    (workspace / "hop.yaml").write_text(MISSION)
    v = await ok(client, "validate_mission", {"path": "hop.yaml"})
    assert v["valid"] and v["mission"]["robots"] == 1
    job = (await ok(client, "run_mission", {"path": "hop.yaml"}))["job"]
    assert job["state"] == "running" and service.world.robot_names() == []  # the live world is untouched
    st = (await ok(client, "mission_status", {"job_id": job["id"], "wait_s": 60}))["job"]
    assert st["state"] == "succeeded" and st["passed"] is True and "PASS" in st["summary"]
    rep = (await ok(client, "mission_report", {"job_id": job["id"], "response_format": "summary"}))["job"]
    assert rep["passed"] and rep["report"]["assertions"] == ["PASS hops"]
    full = (await ok(client, "mission_report", {"job_id": job["id"], "response_format": "full"}))["job"]
    assert full["report"]["assertions"][0]["passed"] is True


async def test_mission_bad_input(client, workspace: Path) -> None:
    (workspace / "typo.yaml").write_text(MISSION.replace("time_limit", "time_limt"))
    text = await err(client, "validate_mission", {"path": "typo.yaml"}, "INVALID_CONFIG")
    assert "time_limt" in text
    await err(client, "run_mission", {"path": "../../etc/m.yaml"}, "NOT_FOUND")
    await err(client, "mission_status", {"job_id": "mission999"}, "NOT_FOUND")
    await err(client, "mission_report", {"job_id": "mission999"}, "NOT_FOUND")
    job = (await ok(client, "run_mission", {"path": "typo.yaml"}))["job"]
    st = (await ok(client, "mission_status", {"job_id": job["id"], "wait_s": 30}))["job"]
    assert st["passed"] is False and "time_limt" in st["error"]


async def test_challenge_grades_a_builtin_controller(client, workspace: Path) -> None:
    names = {c["name"] for c in (await ok(client, "list_challenges"))["challenges"]}
    assert "arena_course" in names
    (workspace / "short_hop.yaml").write_text(CHALLENGE)
    job = (await ok(client, "run_challenge", {"challenge": "short_hop.yaml", "controller": "pure_pursuit"}))["job"]
    st = (await ok(client, "challenge_status", {"job_id": job["id"], "wait_s": 120}))["job"]
    assert st["state"] == "succeeded" and st["success_rate"] == 1.0 and st["mean_score"] > 0
    rep = (await ok(client, "challenge_report", {"job_id": job["id"]}))["job"]["report"]
    assert rep["contestant"] == "builtin:pure_pursuit" and len(rep["runs"]) == 1
    await err(client, "run_challenge", {"challenge": "short_hop.yaml", "controller": "rocket"}, "INVALID_ARGUMENT")
    await err(client, "run_challenge", {"challenge": "no_such_challenge"}, "NOT_FOUND")
    await err(client, "challenge_report", {"job_id": "nope"}, "NOT_FOUND")


async def test_grade_course_files(client, workspace: Path) -> None:
    r = (await ok(client, "grade_course_file", {"kind": "world",
                                                "path": str(CONFIGS / "worlds" / "robot_arena.world")}))["report"]
    assert r["total"] == 15 and r["earned"] == r["total"]
    await err(client, "grade_course_file", {"kind": "world", "path": "/etc/hosts"}, "NOT_FOUND")
    await err(client, "grade_course_file", {"kind": "robot", "path": "missing.urdf"})
