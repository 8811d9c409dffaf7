"""`fleetnav zenoh` as a user runs it, from a folder outside the checkout: robots spawned by --spawn at a spawn
point and at x,y,yaw, the published rates set by --odom-hz/--state-hz, an unknown robot a clear error, bad
arguments exit 2 with one line, Ctrl-C exits 0."""

from __future__ import annotations

import itertools
import math
import signal
import subprocess
from pathlib import Path

import pytest

from fleet.agent import Agent
from fleet.grading.agent_run import free_port
from sim.errors import ErrorCode, FleetError
from tests.e2e.served_world import cli, env


def test_fleetnav_zenoh_spawns_robots_and_serves_them_from_any_folder(tmp_path: Path):
    port = free_port()
    (tmp_path / "z.yaml").write_text(f"listen: [tcp/127.0.0.1:{port}]\nmulticast_scouting: false\n")
    proc = subprocess.Popen(cli("zenoh", "--config", "z.yaml", "--spawn", "r1@start", "--spawn", "r2@-5,-3,1.5",
                                "--control-hz", "20", "--odom-hz", "10", "--state-hz", "5", "--speed", "2"),
                            cwd=tmp_path, env=env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        with Agent("cli_check", connect=f"tcp/127.0.0.1:{port}", timeout=30) as agent:
            state = agent.fleet_state()
            assert state["names"] == ["r1", "r2"] and state["world"] == "robot_arena"
            assert (state["x"][0], state["y"][0]) == pytest.approx((-5.0, -5.0), abs=0.05)  # spawn_start
            assert (state["x"][1], state["y"][1], state["yaw"][1]) == pytest.approx((-5.0, -3.0, 1.5), abs=0.05)
            with pytest.raises(FleetError) as e:
                agent.robot("r9")
            assert e.value.code is ErrorCode.UNKNOWN_ROBOT and "r1, r2" in e.value.message
            r1 = agent.robot("r1", streams=("odom", "pose"))
            odom, pose = stamps(r1, "odom", 6), stamps(r1, "pose", 6)
            # sensor odom at 50 Hz decimated to 10 Hz, pose at 5 Hz (control ticks at 20 Hz): sim-time spacing
            assert all(d == pytest.approx(0.1, abs=0.021) for d in diffs(odom)), diffs(odom)
            assert all(d == pytest.approx(0.2, abs=0.051) for d in diffs(pose)), diffs(pose)
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            _out, err = proc.communicate(timeout=60)  # a loaded machine can take long to shut Zenoh down
        except subprocess.TimeoutExpired:
            proc.kill()
            raise
    assert proc.returncode == 0, err[-2000:]
    assert "robots: r1, r2" in err


def stamps(link: object, stream: str, n: int) -> list[float]:
    got: list[float] = []
    last = -math.inf
    for _ in range(n):
        msg = link.wait(stream, timeout=10, newer_than=last)  # type: ignore[attr-defined]
        last = msg["stamp"] if isinstance(msg, dict) else msg.stamp
        got.append(last)
    return got


def diffs(xs: list[float]) -> list[float]:
    return [b - a for a, b in itertools.pairwise(xs)]


@pytest.mark.parametrize(("args", "says"), [
    (["--spawn", "r1@nowhere"], "no spawn point 'nowhere'"),
    (["--spawn", "r1@1,x"], "is not x,y or x,y,yaw"),
    (["--spawn", "r1", "--spawn", "r1@1,1"], "spawned twice"),
    (["--config", "nope"], "no Zenoh config 'nope'"),
    (["--state-hz", "50"], "state_hz 50 exceeds control_hz 10"),
])
def test_bad_arguments_exit_2_with_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, args: list[str],
                                            says: str):
    from typer.testing import CliRunner

    from fleetnav.cli import app

    monkeypatch.chdir(tmp_path)  # any folder
    res = CliRunner().invoke(app, ["zenoh", *args])
    assert res.exit_code == 2
    lines = [ln for ln in res.stderr.splitlines() if ln.startswith("error:")]
    assert len(lines) == 1 and says in lines[0], res.stderr[-1000:]
