"""Issue 16's reproducers, each a regression test, against a running (threaded) service: hostile input is
refused with a structured error before it reaches the sim thread, and the world keeps stepping."""

from __future__ import annotations

import time
from collections.abc import AsyncIterator, Iterator
from pathlib import Path
from typing import Any

import pytest
from mcp.client import Client
from mcp.server.mcpserver import MCPServer

from fleet import FleetConfig, FleetService
from mcp_server.server import build_server
from sim import Pose2D
from sim.errors import ErrorCode, FleetError
from tests.mcp_server.helpers import err, ok

BOX = ("<sdf version='1.9'><model name='{name}'><static>true</static><pose>{x} 0 0.5 0 0 0</pose><link name='l'>"
       "<collision name='c'><geometry><box><size>{s} 1 1</size></box></geometry></collision></link></model></sdf>")
INCLUDE = "<sdf version='1.9'><model name='inc'><include><uri>{uri}</uri></include></model></sdf>"

REPRODUCERS: list[tuple[str, dict[str, Any], str]] = [
    ("spawn_robot", {"name": "a", "x": 1e308, "y": 1e308}, "INVALID_ARGUMENT"),
    ("navigate_to", {"robot": "r1", "x": 1e308, "y": 0}, "INVALID_ARGUMENT"),
    ("navigate_to", {"robot": "r1", "x": 500.0, "y": 0}, "OUT_OF_BOUNDS"),
    ("add_keepout_zone", {"polygon": [["NaN", 0], [1, 0], [1, 1]]}, "INVALID_ARGUMENT"),
    ("add_keepout_zone", {"polygon": [[-1e308, -1e308], [1e308, 0], [1, 1e308]]}, "INVALID_ARGUMENT"),
    ("add_keepout_zone", {"polygon": [[0, 0], [2, 2], [2, 0], [0, 2]]}, "INVALID_ARGUMENT"),  # a bow tie
    ("set_model_state", {"name": "r1", "pose": {"x": 1e308, "y": 1e308}}, "INVALID_ARGUMENT"),
    ("spawn_model", {"xml": BOX.format(name="big", x=0, s="1e308")}, "INVALID_ARGUMENT"),
    ("spawn_model", {"xml": BOX.format(name="far", x="1e308", s=1)}, "INVALID_ARGUMENT"),
    ("spawn_model", {"xml": BOX.format(name="far2", x=0, s=1), "pose": {"x": 1e308}}, "INVALID_ARGUMENT"),
    ("set_simulation_speed", {"speed": 1e-300}, "INVALID_ARGUMENT"),
    ("start_slam", {"robot": "r1", "config": {"mapping": {"resolution": 1e-9}}}, "INVALID_ARGUMENT"),
    ("step_simulation", {"steps": 1_000_000}, "INVALID_ARGUMENT"),
    ("cover_area", {"robot": "r1", "polygon": [[-1e6, -1e6], [1e6, -1e6], [1e6, 1e6], [-1e6, 1e6]],
                    "tool_width": 0.06}, "INVALID_ARGUMENT"),
    ("assign_tasks", {"tasks": [{"type": "go_to", "params": {"goal": {"x": 1, "y": 1}}}] * 3000, "dry_run": True},
     "INVALID_ARGUMENT"),
    ("load_world", {"world": "../../etc/x"}, "INVALID_ARGUMENT"),
    ("load_world", {"world": "../../../../etc/x.world"}, "NOT_FOUND"),
    ("validate_world", {"world": "/etc/passwd.world"}, "NOT_FOUND"),
    ("spawn_robot", {"name": "b", "model": "/etc/hosts.yaml"}, "NOT_FOUND"),
    ("save_world", {"path": "../.github/workflows/ci.world"}, "PATH_NOT_ALLOWED"),
]


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[FleetService, MCPServer, Path]]:
    ws = tmp_path_factory.mktemp("hostile")
    svc = FleetService(FleetConfig(world="empty", seed=1, workspace=str(ws)))
    svc.start("paused")
    yield svc, build_server(svc), ws
    svc.close()


@pytest.fixture
async def client(live: tuple[FleetService, MCPServer, Path]) -> AsyncIterator[Client]:
    svc, server, _ = live
    if not svc.sim_health()["alive"]:
        svc.restart()
    svc.reset()
    svc.pause()
    svc.spawn_robot("r1", Pose2D(0.0, 0.0, 0.0))
    async with Client(server) as c:
        yield c


async def _still_steps(client: Client, svc: FleetService) -> None:
    h = await ok(client, "sim_health")
    assert h["alive"] and h["dead_reason"] is None
    t0 = svc.sim_time
    t = await ok(client, "step_simulation", {"steps": 10})
    assert t["sim_time"] == pytest.approx(t0 + 0.1)


@pytest.mark.anyio
@pytest.mark.parametrize(("tool", "args", "code"), REPRODUCERS, ids=[f"{t}-{i}" for i, (t, _, _) in
                                                                       enumerate(REPRODUCERS)])
async def test_reproducer_is_refused_and_the_world_keeps_stepping(client: Client, live: Any, tool: str,
                                                                   args: dict[str, Any], code: str) -> None:
    svc = live[0]
    text = await err(client, tool, args, code)
    assert "sim_time:" in text, "errors carry the sim time too"
    assert "validation error" not in text and "pydantic" not in text  # no raw dumps
    await _still_steps(client, svc)


@pytest.mark.anyio
async def test_a_command_that_raises_fails_alone(client: Client, live: Any) -> None:
    svc = live[0]
    with pytest.raises(FleetError) as e:
        svc.call(lambda: 1 / 0)
    assert e.value.code is ErrorCode.INTERNAL and "ZeroDivisionError" in e.value.message
    assert svc.sim_health()["command_errors"] >= 1
    await _still_steps(client, svc)


@pytest.mark.anyio
async def test_an_overrunning_command_is_stopped_and_others_run(client: Client, live: Any) -> None:
    svc = live[0]
    fut = svc.submit(lambda: svc._step(10_000_000), budget=0.3)  # ~30 min of stepping, stopped at its budget
    with pytest.raises(FleetError) as e:
        fut.result(timeout=30)
    assert e.value.code is ErrorCode.TIMEOUT and "budget" in e.value.message
    assert svc.sim_health()["overruns"] >= 1
    await _still_steps(client, svc)


@pytest.mark.anyio
async def test_a_dead_sim_thread_fails_fast_says_why_and_restarts_from_the_snapshot(client: Client,
                                                                                     live: Any) -> None:
    svc = live[0]
    svc.set_model_state("r1", None)
    await ok(client, "step_simulation", {"steps": 50})
    await ok(client, "save_snapshot", {"name": "before"})

    def boom(_: float) -> None:
        raise SystemExit("injected fault")

    svc.control_gate = boom
    svc.resume(5.0)
    deadline = time.monotonic() + 10
    while svc.sim_health()["alive"] and time.monotonic() < deadline:
        time.sleep(0.02)
    svc.control_gate = None
    h = await ok(client, "sim_health")
    assert not h["alive"] and "SystemExit" in h["dead_reason"] and h["last_snapshot"] == "before"
    t0 = time.monotonic()
    text = await err(client, "get_model_state", {"name": "r1"}, "SIM_DEAD")
    assert time.monotonic() - t0 < 5 and "injected fault" in text
    with pytest.raises(FleetError) as e:
        svc.step(1)
    assert e.value.code is ErrorCode.SIM_DEAD
    r = await ok(client, "restart_simulation")
    assert r["restored_from"] == "snapshot 'before'" and r["robots"] == ["r1"]
    assert r["sim_time"] == pytest.approx(0.5, abs=0.011)  # the snapshot's time (taken between steps)
    svc.pause()
    await _still_steps(client, svc)


@pytest.mark.anyio
async def test_file_uris_and_symlinks_cannot_leave_the_workspace(client: Client, live: Any, tmp_path: Path) -> None:
    _, _, ws = live
    secret = tmp_path / "secret.sdf"
    secret.write_text(BOX.format(name="s", x=0, s=1))
    (ws / "link.sdf").symlink_to(secret)
    outside = await err(client, "spawn_model", {"xml": INCLUDE.format(uri=f"file://{secret}")}, "NOT_FOUND")
    missing = await err(client, "spawn_model", {"xml": INCLUDE.format(uri=f"file://{tmp_path}/none.sdf")},
                        "NOT_FOUND")

    def strip(t: str) -> str:
        return t.split("| sim_time")[0].replace(str(secret), "X").replace(f"{tmp_path}/none.sdf", "X")

    assert strip(outside) == strip(missing), "a forbidden file answers exactly like a missing one"
    a = await err(client, "spawn_model", {"file": "link.sdf"}, "NOT_FOUND")
    b = await err(client, "spawn_model", {"file": "nothing.sdf"}, "NOT_FOUND")
    assert a.replace("link.sdf", "X").split("| sim_time")[0] == b.replace("nothing.sdf", "X").split("| sim_time")[0]
    mesh = ("<sdf version='1.9'><model name='m'><static>true</static><link name='l'><collision name='c'><geometry>"
            f"<mesh><uri>{tmp_path}/m.obj</uri></mesh></geometry></collision></link></model></sdf>")
    (tmp_path / "m.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    await err(client, "spawn_model", {"xml": mesh})


@pytest.mark.anyio
async def test_writes_stay_in_outputs_and_never_overwrite_foreign_files(client: Client, live: Any) -> None:
    _, _, ws = live
    out = ws / "outputs"
    out.mkdir(exist_ok=True)
    (out / "keep.world").write_text("precious")
    await err(client, "save_world", {"path": "keep.world"}, "PATH_NOT_ALLOWED")
    assert (out / "keep.world").read_text() == "precious"
    await ok(client, "save_world", {"path": "keep.world", "overwrite": True})
    assert "<sdf" in (out / "keep.world").read_text()
    await ok(client, "save_world", {"path": "mine.world"})
    await ok(client, "save_world", {"path": "mine.world"})  # its own file: no flag needed
    await err(client, "save_world", {"path": str(ws / "top.world")}, "PATH_NOT_ALLOWED")  # root, not outputs


def test_no_workspace_at_root_or_home(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from fleet.workspace import Workspace

    for bad in ("/", str(Path.home())):
        with pytest.raises(FleetError) as e:
            Workspace(bad)
        assert e.value.code is ErrorCode.INVALID_CONFIG
    monkeypatch.setenv("FLEETNAV_WORKSPACE", str(tmp_path / "dedicated"))
    assert Workspace(None).root == (tmp_path / "dedicated").resolve()
    assert FleetConfig().workspace is None


@pytest.mark.anyio
async def test_read_only_is_enforced_by_the_service(live: Any) -> None:
    svc = live[0]
    svc.reset()
    svc.spawn_robot("r1", Pose2D(0.0, 0.0, 0.0))
    server = build_server(svc, read_only=True)
    try:
        async with Client(server) as c:
            t0 = svc.sim_time
            p = await ok(c, "profile_simulation", {"steps": 500})
            assert p["steps"] == 500 and svc.sim_time == pytest.approx(t0)  # measured, then put back
        with pytest.raises(FleetError) as e:
            svc.spawn_robot("r2", Pose2D(1.0, 0.0, 0.0))
        assert e.value.code is ErrorCode.UNSUPPORTED
    finally:
        svc.read_only = False


@pytest.mark.anyio
async def test_leases_belong_to_the_session(client: Client, live: Any) -> None:
    """Two sessions (initialize handshake, as stdio and session HTTP do) are two clients."""
    _, server, _ = live
    async with Client(server, mode="legacy") as mine, Client(server, mode="legacy") as other:
        await _lease_check(mine, other)


async def _lease_check(client: Client, other: Client) -> None:
    await ok(client, "acquire_lease", {"robot": "r1"})
    await err(other, "drive_robot", {"robot": "r1", "v": 0.2, "w": 0.0, "wait": False}, "LEASE_HELD")
    await err(other, "navigate_to", {"robot": "r1", "x": 2.0, "y": 0.0}, "LEASE_HELD")
    released = await ok(other, "release_lease", {"robot": "r1"})
    assert "held no lease" in released["message"]
    await ok(client, "drive_robot", {"robot": "r1", "v": 0.2, "w": 0.0, "wait": False})


@pytest.mark.anyio
async def test_navigate_is_refused_while_estopped(client: Client, live: Any) -> None:
    svc = live[0]
    await ok(client, "emergency_stop", {"robot": "r1"})
    await err(client, "navigate_to", {"robot": "r1", "x": 2.0, "y": 0.0}, "ESTOPPED")
    await ok(client, "emergency_stop", {})
    await err(client, "follow_waypoints", {"robot": "r1", "waypoints": [{"x": 1, "y": 1}]}, "ESTOPPED")
    await ok(client, "rearm", {})
    await ok(client, "rearm", {"robot": "r1"})
    assert not svc.list_tasks("r1")


@pytest.mark.anyio
async def test_time_is_read_after_the_command_and_reset_does_not_catch_up(client: Client, live: Any) -> None:
    svc = live[0]
    t = await ok(client, "step_simulation", {"steps": 7})
    assert t["sim_time"] == pytest.approx(0.07)  # not the snapshot of the last control tick (0.0)
    svc.step(2000)
    svc.resume(1.0)
    await ok(client, "reset_simulation")
    time.sleep(0.3)
    assert svc.sim_time < 5.0, "after a reset the clock paces from 0, it does not race back to 20 s"
    svc.pause()
