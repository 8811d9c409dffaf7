"""Malformed payloads from another process: rejected with an error reply (or an error report), logged, and the
world keeps running and obeying good commands."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from fleet.agent import Agent
from sim.errors import ErrorCode, FleetError
from tests.fleet.zenoh_util import served, wait_until

# A raw Zenoh client (no fleetnav import): garbage on cmd_vel, a navigate query with a wrong type.
SENDER = r"""
import json, sys, threading, zenoh
ep, base = sys.argv[1], sys.argv[2]
c = zenoh.Config()
for k, v in (("mode", "client"), ("connect/endpoints", [ep]), ("scouting/multicast/enabled", False)):
    c.insert_json5(k, json.dumps(v))
with zenoh.open(c) as s:
    errors, two = [], threading.Event()
    def on_error(x):
        errors.append(json.loads(x.payload.to_bytes()))
        if len(errors) >= 2:
            two.set()
    sub = s.declare_subscriber(base + "/fleet/errors", on_error)
    s.liveliness().get(base + "/alive/world", timeout=5).recv()  # the world is reachable
    s.put(base + "/robot/r1/cmd_vel", b"{not json")
    s.put(base + "/robot/r1/cmd_vel", b'{"v": 1e999, "w": 0}')
    replies = [{"error": r.err is not None, **json.loads((r.err or r.ok).payload.to_bytes())}
               for r in s.get(base + "/fleet/command/navigate", payload=b'{"robot": "r1", "goal": {"x": "far"}}',
                              timeout=10)]
    two.wait(10)
    print(json.dumps({"replies": replies, "errors": errors}))
"""


def test_malformed_payloads_are_rejected_logged_and_the_world_keeps_running(caplog):
    with served(robots={"r1": (0.0, 0.0, 0.0)}) as (svc, bridge, ep), Agent("victim", connect=ep) as agent:
        out = subprocess.run([sys.executable, "-c", SENDER, ep, agent.keys.base], capture_output=True, text=True,
                             timeout=60)
        assert out.returncode == 0, out.stderr[-2000:]
        got = json.loads(out.stdout)
        [reply] = got["replies"]
        assert reply["error"] and reply["code"] == "INVALID_ARGUMENT" and "goal.x" in reply["message"]
        assert [e["code"] for e in got["errors"]] == ["INVALID_ARGUMENT"] * 2
        assert "not JSON" in got["errors"][0]["message"] and "field 'v'" in got["errors"][1]["message"]
        assert got["errors"][0]["key"].endswith("/robot/r1/cmd_vel") and got["errors"][0]["agent"] is None
        assert bridge.stats()["commands"]["malformed"] == 2
        assert sum("malformed command" in r.message for r in caplog.records) == 2  # and both were logged
        with pytest.raises(FleetError) as e:
            agent.request("teleport", robot="r1")
        assert e.value.code is ErrorCode.NOT_FOUND and "navigate" in e.value.hint
        t = svc.snapshot.time  # still stepping, still obeying good commands
        assert agent.robot("r1").drive_sync(0.4, 0.0)["applied_v"] == 0.4
        wait_until(lambda: svc.snapshot.time > t + 0.3 and svc.snapshot.robot("r1").v > 0.1, what="motion")
