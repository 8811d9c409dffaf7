"""A Hypothesis state machine over the Zenoh API (a real Zenoh client session on loopback, scouting off, against a
served world): hostile values (NaN, ±inf, 1e308, huge numbers and payloads, deep nesting, `../`, absolute
paths, `file://`, wrong types, unicode, not-JSON bytes, odd keys) in queries and velocity commands, interleaved
with normal calls. After every step the sim thread is alive with no failed command, sim time advances, every
query is answered within ANSWER_S (a world too slow to answer says TIMEOUT within its query budget), and every
error reply (and every error report on `fleet/errors`) is a structured FleetError code (never INTERNAL).

Bounded for CI: derandomized, a fixed number of examples and steps. The counts are printed (`-s`) and recorded in
docs/limits.md next to the MCP machine's.
"""

from __future__ import annotations

import json
import threading
import time
from collections import Counter
from collections.abc import Iterator
from typing import Any

import pytest
import zenoh
from hypothesis import HealthCheck, Phase, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, initialize, invariant, rule, run_state_machine_as_test

from fleet import FleetService
from fleet.zenoh_api import Keys
from sim.errors import ErrorCode
from tests.fleet.zenoh_util import served, wait_until

CODES = set(ErrorCode.__members__) - {"INTERNAL", "SIM_DEAD"}
NAN, INF = float("nan"), float("inf")
HOSTILE: list[Any] = [
    NAN, INF, -INF, 1e308, -1e308, 10**30, -(10**12), 0, -1, "NaN", "", "../../etc/passwd", "/etc/shadow",
    "file:///etc/passwd", "机器人\u202e\x00", "a" * 20000, [], {}, None, True, [[1e308, 0]], {"x": NAN},
    {"x": 1e308, "y": -1e308}, {"x": "far", "y": 0},
]
# Payloads that are not a JSON object of the right shape at all.
RAW: list[bytes] = [b"{not json", b"\xff\xfe\x00", b"[]", b"1e999", b"null", b'"str"', b"[" * 100_000,
                    b'{"a":' * 50_000, b"{" + b'"k": 1,' * 20_000 + b'"z": 0}', b"NaN", b"{}" * 1000]
# op → (fields to make hostile, the other fields of a sensible request)
OPS: dict[str, tuple[list[str], dict[str, Any]]] = {
    "navigate": (["robot", "goal", "align_yaw", "agent"], {"robot": "r1", "goal": {"x": 1.0, "y": 1.0}}),
    "spawn": (["name", "pose", "model", "fidelity", "namespace"], {"name": "h1", "pose": {"x": 2.0, "y": 2.0}}),
    "drive": (["robot", "v", "w", "duration", "agent"], {"robot": "r1", "v": 0.1, "w": 0.0, "duration": 0.2}),
    "lease": (["robot", "release", "ttl_s"], {"robot": "r1"}),
    "override": (["robot", "reason", "hold_s"], {"robot": "r1", "hold_s": 0.5}),
    "estop": (["robot", "reason"], {"robot": "r1"}),
    "rearm": (["robot"], {"robot": "r1"}),
    "task_status": (["task_id"], {"task_id": "t1"}),
    "cancel": (["task_id"], {"task_id": "t1"}),
    "remove": (["name"], {"name": "h1"}),
    "lockstep": (["robots"], {"robots": ["r1"]}),
}
STATS: Counter[str] = Counter()
FAILURES: list[str] = []
SLOW: list[str] = []  # calls answered after > 5 s
ANSWER_S = 10.0  # the caller's patience; the bridge's query budget (5 s) is below it


class Link:
    """A raw Zenoh client (no fleetnav Agent): sends whatever bytes it is given, collects error reports."""

    def __init__(self, endpoint: str, keys: Keys) -> None:
        c = zenoh.Config()
        for k, v in (("mode", "client"), ("connect/endpoints", [endpoint]), ("scouting/multicast/enabled", False)):
            c.insert_json5(k, json.dumps(v))
        self.session, self.keys = zenoh.open(c), keys
        self.reports: list[dict[str, Any]] = []
        self._lock = threading.Lock()
        self.sub = self.session.declare_subscriber(keys.fleet("errors"), self._on_error)

    def _on_error(self, sample: zenoh.Sample) -> None:
        with self._lock:
            self.reports.append(json.loads(sample.payload.to_bytes()))

    def take_reports(self) -> list[dict[str, Any]]:
        with self._lock:
            out, self.reports = self.reports, []
        return out

    def get(self, key: str, payload: bytes | None) -> list[tuple[bool, Any]]:
        replies = self.session.get(key, payload=payload, timeout=ANSWER_S) if payload is not None else \
            self.session.get(key, timeout=ANSWER_S)
        out: list[tuple[bool, Any]] = []
        for r in replies:
            sample = r.err if r.err is not None else r.ok
            assert sample is not None
            raw = sample.payload.to_bytes()
            try:
                out.append((r.err is not None, json.loads(raw)))
            except ValueError:  # e.g. Zenoh's own "Timeout" when the world did not answer in time
                out.append((r.err is not None, raw.decode(errors="replace")))
        return out

    def close(self) -> None:
        self.sub.undeclare()
        self.session.close()


def _body(d: dict[str, Any]) -> bytes:
    return json.dumps(d, allow_nan=True).encode()


class HostileZenoh(RuleBasedStateMachine):
    svc: FleetService
    link: Link

    @initialize()
    def fresh(self) -> None:
        svc = HostileZenoh.svc
        if not svc.sim_health()["alive"]:
            svc.restart()
        [(is_err, _)] = self.command("reset", {})  # through the API: the bridge's gate sees it
        assert not is_err
        self.robots = 0
        self.spawn()

    @property
    def keys(self) -> Keys:
        return HostileZenoh.link.keys

    def query(self, key: str, payload: bytes | None, hostile: bool) -> list[tuple[bool, Any]]:
        STATS["calls"] += 1
        STATS["hostile" if hostile else "normal"] += 1
        t0 = time.monotonic()
        try:
            replies = HostileZenoh.link.get(key, payload)
        except zenoh.ZError as exc:  # the client library refuses the key itself: nothing reached the world
            STATS["refused_by_zenoh"] += 1
            assert hostile, f"{key}: {exc}"
            return []
        if time.monotonic() - t0 > 5:
            SLOW.append(f"{key} ← {(payload or b'')[:80]!r}: {time.monotonic() - t0:.1f} s")
        if not replies:
            FAILURES.append(f"{key} ← {(payload or b'')[:80]!r}: no reply")
        assert replies, f"{key}: no reply"
        for is_err, msg in replies:
            if is_err and msg == "Timeout":  # Zenoh's own: nobody answered (or finalized the query) in ANSWER_S
                STATS["unanswered"] += 1
                FAILURES.append(f"{key} ← {(payload or b'')[:80]!r}: no answer in {ANSWER_S:g} s")
            assert not (is_err and msg == "Timeout"), f"{key} ← {(payload or b'')[:80]!r}: unanswered"
            if is_err and isinstance(msg, dict) and msg.get("code") == "TIMEOUT":
                STATS["timeouts"] += 1
            if is_err:
                STATS["errors"] += 1
                if not (isinstance(msg, dict) and msg.get("code") in CODES and msg.get("message")):
                    FAILURES.append(f"{key} ← {(payload or b'')[:80]!r} → {str(msg)[:200]}")
                assert isinstance(msg, dict) and msg.get("code") in CODES, \
                    f"{key} ← {(payload or b'')[:80]!r}: unstructured {str(msg)[:300]}"
                assert isinstance(msg.get("stamp", msg.get("sim_time")), float | int), f"{key}: error without time"
        return replies

    def command(self, op: str, body: dict[str, Any], hostile: bool = False) -> list[tuple[bool, Any]]:
        return self.query(self.keys.command(op), _body({"agent": "machine"} | body), hostile)

    @rule()
    def spawn(self) -> None:
        [(is_err, _)] = self.command("spawn", {"name": f"r{self.robots + 1}",
                                              "pose": {"x": -4.0 + 1.5 * self.robots, "y": -3.0}})
        self.robots += 0 if is_err else 1

    @rule(x=st.floats(-3, 3), y=st.floats(-3, 3))
    def navigate(self, x: float, y: float) -> None:
        self.command("navigate", {"robot": "r1", "goal": {"x": x, "y": y}})

    @rule(v=st.floats(-0.3, 0.3), w=st.floats(-0.5, 0.5))
    def drive(self, v: float, w: float) -> None:
        self.command("drive", {"robot": "r1", "v": v, "w": w, "duration": 0.3})

    @rule()
    def look(self) -> None:
        [(is_err, state)] = self.query(self.keys.fleet("state"), None, hostile=False)
        assert not is_err and isinstance(state, dict)
        [(is_err, _)] = self.query(self.keys.fleet("tasks"), _body({"include_done": True}), hostile=False)
        assert not is_err

    @rule()
    def estop_and_rearm(self) -> None:
        self.command("estop", {"robot": "r1"})
        self.command("rearm", {"robot": "r1"})

    @rule(op=st.sampled_from(sorted(OPS)), data=st.data())
    def hostile_field(self, op: str, data: st.DataObject) -> None:
        fields, base = OPS[op]
        field = data.draw(st.sampled_from(fields), label="field")
        value = data.draw(st.sampled_from(HOSTILE), label="value")
        self.command(op, {**base, field: value}, hostile=True)

    @rule(op=st.sampled_from(sorted(OPS)), data=st.data())
    def hostile_field_again(self, op: str, data: st.DataObject) -> None:  # two rules: more hostile steps
        self.hostile_field(op, data)

    @rule(key=st.sampled_from(["fleet/command/navigate", "fleet/command/spawn", "fleet/command/drive",
                               "fleet/command/lease", "fleet/tasks", "robot/r1/camera", "fleet/command/reset_all",
                               "fleet/command/..", "fleet/command/estop"]),
          raw=st.sampled_from(RAW))
    def hostile_bytes(self, key: str, raw: bytes) -> None:
        self.query(f"{self.keys.base}/{key}", raw, hostile=True)

    @rule(key=st.sampled_from(["fleet/command/%2e%2e", "robot/../camera", "robot/机器人/camera", "robot/r1/camera",
                               "fleet/command/*", "fleet/map", "fleet/command/" + "x" * 3000, "robot/%00/camera",
                               "fleet/state", "robot/*/camera"]),
          which=st.sampled_from([None, {"which": "depth"}, {"which": "../../etc/passwd"}, {"which": NAN}]))
    def hostile_key(self, key: str, which: dict[str, Any] | None) -> None:
        self.query(f"{self.keys.base}/{key}", None if which is None else _body(which), hostile=True)

    @rule(v=st.sampled_from(HOSTILE), robot=st.sampled_from(["r1", "..", "机器人", "r1" * 100]))
    def hostile_cmd_vel(self, v: Any, robot: str) -> None:
        STATS["calls"] += 1
        STATS["hostile"] += 1
        HostileZenoh.link.session.put(self.keys.robot(robot, "cmd_vel"), _body({"v": v, "w": 0.0, "agent": "m"}))

    @invariant()
    def alive(self) -> None:
        svc = HostileZenoh.svc
        h = svc.sim_health()
        assert h["alive"] and h["dead_reason"] is None, h
        assert h["command_errors"] == 0, h["recent_errors"]
        t = svc.snapshot.time
        wait_until(lambda: svc.snapshot.time > t, timeout=20, what="sim time to advance")
        for rep in HostileZenoh.link.take_reports():
            STATS["reports"] += 1
            if rep.get("code") not in CODES:
                FAILURES.append(f"report {str(rep)[:200]}")
            assert rep.get("code") in CODES, rep


@pytest.fixture(scope="module")
def zenoh_world() -> Iterator[tuple[FleetService, Link]]:
    with served(robots={}) as (svc, bridge, ep):
        link = Link(ep, bridge.keys)
        try:
            yield svc, link
        finally:
            link.close()


def test_hostile_zenoh_state_machine(zenoh_world: tuple[FleetService, Link]) -> None:
    HostileZenoh.svc, HostileZenoh.link = zenoh_world
    STATS.clear()
    FAILURES.clear()
    run_state_machine_as_test(HostileZenoh, settings=settings(
        max_examples=6, stateful_step_count=25, derandomize=True, database=None, deadline=None,
        phases=(Phase.explicit, Phase.generate), suppress_health_check=list(HealthCheck)))  # no shrinking: bounded
    print(f"\nhostile zenoh state machine: {dict(STATS)}; failures: {len(FAILURES)}; replies > 5 s: {SLOW}")
    assert STATS["hostile"] >= 20 and not FAILURES, (FAILURES, SLOW)


@pytest.mark.parametrize("raw", [b"[" * 100_000, b'{"a":' * 50_000])
def test_a_deeply_nested_payload_is_invalid_argument_not_internal(raw: bytes) -> None:
    """Found by the machine: json.loads raised RecursionError, which the bridge answered as INTERNAL (and which
    would escape the cmd_vel callback)."""
    from fleet.zenoh_api import NavigateReq, decode
    from sim.errors import FleetError

    with pytest.raises(FleetError) as e:
        decode(NavigateReq, raw, "navigate")
    assert e.value.code is ErrorCode.INVALID_ARGUMENT and "nests too deeply" in e.value.message
