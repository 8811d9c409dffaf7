"""The narrow fleet view: avoidance and deadlock detection run alone on a hand-built view (no FleetService, no
PyBullet) against closed forms; the subsystems do not import the service (checked on the real import graph)."""

from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np
import pytest

from fleet.avoidance import OrcaFilter
from fleet.deadlock import DeadlockConfig, DeadlockMonitor
from fleet.fleet_view import RobotArrays
from fleet.swarm import BehaviourManager
from fleet.swarm.unicycle import OFFSET
from fleet.tasks import TaskManager
from fleet.tasks.basic import GoToTask
from sim import ErrorCode, FleetError, Pose2D
from tests.fleet.fleet_view_util import HandView

ROOT = Path(__file__).resolve().parents[2]


# ---- ORCA on a hand-built view ---------------------------------------------------------------------------------


def _head_on() -> HandView:
    view = HandView(["a", "b"], [[-1.0, 0.0, 0.0], [1.0, 0.0, math.pi]])
    view.owners = {"a": "task:1", "b": "task:2"}  # both driven by autonomy: they share the avoidance
    return view


def _tracked(view: HandView, cmd: dict[str, tuple[float, float]], off: float) -> tuple[np.ndarray, np.ndarray]:
    """Points `off` ahead of the axles and their planar velocities u = v·h + off·ω·h⊥ under `cmd`."""
    p, u = [], []
    for i, n in enumerate(view.names):
        x, y, yaw = view.pose[i]
        h, hp = np.array([math.cos(yaw), math.sin(yaw)]), np.array([-math.sin(yaw), math.cos(yaw)])
        v, w = cmd[n]
        p.append(np.array([x, y]) + off * h)
        u.append(v * h + off * w * hp)
    return np.array(p), np.array(u)


def _closest_within(rel_p: np.ndarray, rel_u: np.ndarray, tau: float) -> float:
    """min over t in [0, tau] of |rel_p + t rel_u| (closed form: the clamped minimiser of a quadratic)."""
    t = float(np.clip(-(rel_p @ rel_u) / max(float(rel_u @ rel_u), 1e-12), 0.0, tau))
    return float(np.hypot(*(rel_p + t * rel_u)))


def test_orca_head_on_is_symmetric_and_leaves_the_velocity_obstacle():
    view, orca = _head_on(), OrcaFilter()
    desired = {"a": (0.5, 0.0), "b": (0.5, 0.0)}
    out = orca.filter(view, desired)
    off, comb = orca.offset, 2 * (0.2 + orca.offset + orca.margin)  # the inflated discs of the tracked points
    p, u_want = _tracked(view, desired, off)
    _, u = _tracked(view, out, off)
    # straight at each other the wanted velocities collide within the horizon; ORCA's do not
    assert _closest_within(p[1] - p[0], u_want[1] - u_want[0], orca.tau) < comb - 0.5
    assert _closest_within(p[1] - p[0], u[1] - u[0], orca.tau) >= comb - 1e-6
    # identical robots, mirrored: the same (v, ω) each, i.e. point-symmetric planar velocities (reciprocity)
    assert out["a"] == pytest.approx(out["b"], abs=1e-12)
    np.testing.assert_allclose(u[0], -u[1], atol=1e-12)
    assert out["a"][1] < 0  # both turn clockwise: each passes the other on its right
    assert 0 < out["a"][0] < 0.5


def test_orca_head_on_run_passes_without_contact_and_stays_point_symmetric():
    view, orca = _head_on(), OrcaFilter()
    goals, dt, closest = np.array([[3.0, 0.0], [-3.0, 0.0]]), view.control_dt, math.inf
    for _ in range(120):
        desired = {}
        for i, n in enumerate(view.names):  # a go-to-goal controller: 0.5 m/s, turn towards the goal
            d = goals[i] - view.pose[i, :2]
            err = (math.atan2(d[1], d[0]) - view.pose[i, 2] + math.pi) % (2 * math.pi) - math.pi
            desired[n] = (0.5 if np.hypot(*d) > 0.1 else 0.0, float(np.clip(2.0 * err, -2.0, 2.0)))
        out = orca.filter(view, desired)
        for i, n in enumerate(view.names):  # unicycle integration of what ORCA let through
            v, w = out[n]
            view.twist[i] = (v, w)
            view.pose[i] += (v * math.cos(view.pose[i, 2]) * dt, v * math.sin(view.pose[i, 2]) * dt, w * dt)
        view.now += dt
        closest = min(closest, float(np.hypot(*(view.pose[0, :2] - view.pose[1, :2]))))
        np.testing.assert_allclose(view.pose[0, :2], -view.pose[1, :2], atol=1e-9)
    assert closest > 2 * 0.2  # the footprint circles never touched
    assert orca.adjusted > 0
    np.testing.assert_allclose(view.pose[:, :2], goals, atol=0.15)  # and both got through


def test_passive_robot_is_avoided_fully_by_the_active_one():
    view, orca = _head_on(), OrcaFilter()
    view.owners = {"a": "task:1"}  # b is idle: a takes the whole avoidance
    out = orca.filter(view, {"a": (0.5, 0.0), "b": (0.0, 0.0)})
    p, u = _tracked(view, {"a": out["a"], "b": (0.0, 0.0)}, orca.offset)
    assert out["a"] != (0.5, 0.0)
    assert _closest_within(p[1] - p[0], u[1] - u[0], orca.tau) >= 2 * (0.2 + orca.offset + orca.margin) - 1e-6


# ---- deadlock detection on a hand-built view ------------------------------------------------------------------


def _cycle_view(priorities: dict[str, int]) -> HandView:
    """a, b, c on a triangle (side ≈ 1.04 m), each facing the next; d behind a, facing it (waits, not in the cycle)."""
    r = 0.6
    pts = {n: r * np.array([math.cos(a), math.sin(a)]) for n, a in zip("abc", np.radians([90, 210, 330]), strict=True)}
    nxt = {"a": "b", "b": "c", "c": "a"}
    pose = [[*pts[n], math.atan2(*(pts[nxt[n]] - pts[n])[::-1])] for n in "abc"]
    back = pts["a"] + 0.7 * np.array([0.0, 1.0])
    pose.append([*back, -math.pi / 2])
    view = HandView(["a", "b", "c", "d"], np.array(pose))
    for k, n in enumerate("abcd"):  # every robot navigates (a go-to task with a real navigator, still planning)
        task = GoToTask(id=f"t{k}", robot=n, params={"goal": {"x": 4.0, "y": 4.0}}, priority=priorities.get(n, 0))
        task.nav = view.make_navigator(n)
        task.nav.set_goal(Pose2D(4.0, 4.0, 0.0), 0.0)
        view.tasks[n] = task
        view.owners[n] = f"task:{task.id}"
    return view


def test_three_cycle_is_detected_with_its_robots_and_resolved_by_priority():
    view = _cycle_view({"b": 5})
    cfg = DeadlockConfig(block_angle=0.5)  # 'ahead' within ±0.5 rad: each of a, b, c blocks only the next
    mon = DeadlockMonitor(view, cfg)
    for k in range(int(cfg.wait_s / cfg.check_period_s) + 1):  # nobody moves
        view.now = k * cfg.check_period_s
        cmds = mon.commands(view.now)
        if view.events:
            break
    assert view.now == pytest.approx(cfg.wait_s)  # declared at the first check after wait_s without progress
    (stamp, kind, robots, message, data), = view.events
    assert (stamp, kind, robots, data["type"], data["winner"]) == (view.now, "deadlock", ("a", "b", "c"), "cycle", "b")
    assert message == "deadlock (cycle) between a, b, c: b goes first; a, c back off and yield"
    assert mon._blockers("d", view.robots.xy) == {"a"}  # d waits on a, but it is not part of the cycle
    assert cmds["b"] == (0.0, 0.0)  # the winner holds while the others back off
    for loser in ("a", "c"):
        assert cmds[loser] != (0.0, 0.0)
        assert mon.owner(loser) == mon.owner("b") == f"deadlock:{data['id']}"
    assert mon.owner("d") is None


def test_a_chain_is_not_a_deadlock():
    view = _cycle_view({})
    view.pose[2, 2] += math.pi  # c turns away from a: a → b → c, no cycle
    mon = DeadlockMonitor(view, DeadlockConfig(block_angle=0.5))
    for k in range(8):  # up to 3.5 s: past wait_s, before stall_s
        view.now = 0.5 * k
        mon.commands(view.now)
    assert view.events == []


# ---- tasks and a swarm behaviour on a hand-built view ----------------------------------------------------------


def test_task_manager_alone_runs_a_wait_and_holds_it_while_e_stopped():
    view = HandView(["a"], [[0.0, 0.0, 0.0]])
    tasks = TaskManager(view)
    with pytest.raises(FleetError) as exc:
        tasks.submit("wait", "zz", {"seconds": 1.0})
    assert exc.value.code is ErrorCode.UNKNOWN_ROBOT
    task = tasks.submit("wait", "a", {"seconds": 1.0})
    view.stopped.add("a")
    for k in range(16):  # 0 … 1.5 s; released from the e-stop at 1.2 s
        view.now = 0.1 * k
        if view.now > 1.15:
            view.stopped.discard("a")
        assert tasks.commands(view.now).get("a", (0.0, 0.0)) == (0.0, 0.0)  # none once it finished
    kinds = [(round(t, 6), kind) for t, kind, *_ in view.events]
    assert kinds == [(0.0, "task_started"), (1.2, "task_finished")]  # due at 1.0, but e-stopped until 1.2
    assert task.state.done and task.finished == pytest.approx(1.2)


def test_rendezvous_alone_commands_the_consensus_velocity():
    pose = [[-2.0, 0.0, 0.0], [2.0, 1.0, 1.0], [0.0, -3.0, -2.0]]
    view = HandView(["a", "b", "c"], pose)
    beh = BehaviourManager(view)
    run = beh.start("rendezvous", ["a", "b", "c"], {"gain": 0.05, "w_separation": 0.0, "max_speed": 0.3})
    assert sorted(r for r, _ in view.released) == ["a", "b", "c"]
    assert [e[1] for e in view.events] == ["behaviour_started"] and beh.owner("a") == f"behaviour:{run.id}"
    cmd = beh.commands(0.0)
    p = np.array(pose)
    h = np.column_stack([np.cos(p[:, 2]), np.sin(p[:, 2])])
    pts = p[:, :2] + OFFSET * h
    want = 0.05 * 3 * (pts.mean(axis=0) - pts)  # k·n·(c − p_i) on the complete graph
    want *= min(1.0, 0.3 / float(np.hypot(*want.T).max()))  # one factor for all: the centroid stays put
    for i, n in enumerate("abc"):  # the unicycle command moves the tracked point at exactly that velocity
        v, w = cmd[n]
        u = v * h[i] + OFFSET * w * np.array([-h[i, 1], h[i, 0]])
        np.testing.assert_allclose(u, want[i], atol=1e-9)
    assert beh.avoidance_group("a") == int(run.id[1:])  # it keeps its robots apart itself


# ---- the view's arrays ----------------------------------------------------------------------------------------


def test_robot_arrays_are_read_only_views_that_name_unknown_robots():
    x = np.array([1.0, 2.0])
    cols = {c: np.zeros(2) for c in ("y", "yaw", "v", "w", "radius", "max_v", "max_w")}
    arr = RobotArrays.of(["r1", "r2"], {"x": x, **cols})
    x[1] = 5.0  # the source moves: the view follows without a copy
    assert arr.pose_of("r2").x == 5.0
    with pytest.raises(ValueError):
        arr.x[0] = 3.0
    with pytest.raises(FleetError) as exc:
        arr.index("r9")
    assert exc.value.code is ErrorCode.UNKNOWN_ROBOT and "r1" in str(exc.value)
    with pytest.raises(ValueError):
        RobotArrays.of(["r1"], {"x": x, **cols})


# ---- the import graph -----------------------------------------------------------------------------------------

SUBSYSTEMS = ("fleet.tasks", "fleet.avoidance", "fleet.swarm", "fleet.deadlock", "fleet.formations",
              "fleet.allocation", "fleet.sync", "fleet.fleet_view")
SERVICE = ("fleet.service", "fleet.core", "fleet.service_view", "fleet.control")


def _fleet_imports() -> dict[str, set[str]]:
    """module → fleet modules it imports anywhere (module level, TYPE_CHECKING blocks, inside functions)."""
    files = {}
    for p in (ROOT / "fleet").rglob("*.py"):
        parts = p.relative_to(ROOT).with_suffix("").parts
        files[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = p

    def resolve(name: str) -> str | None:
        while name and name not in files:
            name = name.rpartition(".")[0]
        return name or None

    graph: dict[str, set[str]] = {}
    for mod, path in files.items():
        out: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                out.update(t for a in node.names if (t := resolve(a.name)))
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                out.update(t for a in node.names if (t := resolve(f"{node.module}.{a.name}") or resolve(node.module)))
        graph[mod] = out - {mod}
    return graph


def _reach(graph: dict[str, set[str]], start: str) -> set[str]:
    seen, todo = set(), [start]
    while todo:
        for t in graph.get(todo.pop(), set()):
            if t not in seen:
                seen.add(t)
                todo.append(t)
    return seen


def test_subsystems_do_not_import_the_service_and_sit_on_no_import_cycle():
    graph = _fleet_imports()
    # the parser sees module-level, TYPE_CHECKING and function-level imports (else the checks below are empty)
    assert "fleet.deadlock" in graph["fleet.ops_fleet"] and "fleet.service" in graph["fleet.service_view"]
    assert "fleet.tasks" in graph["fleet.core"]
    mods = [m for m in graph if m.startswith(SUBSYSTEMS)]
    assert len(mods) > 40
    for m in mods:
        reached = _reach(graph, m)
        assert not reached & set(SERVICE) and not any(r.startswith("fleet.ops_") for r in reached), \
            f"{m} reaches {sorted(r for r in reached if r in SERVICE or r.startswith('fleet.ops_'))}"
        assert m not in reached, f"{m} is on an import cycle"
