"""Typed task params (issue 16): every task type has a params model, and the service checks it for every door
(Python `submit_task`, `queue_task`, `assign_tasks`; MCP, Zenoh and missions call these)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from fleet import FleetConfig, FleetService, task_params
from fleet.tasks import task_types
from fleet.validation import MAX_COVERAGE_LANES
from sim import Pose2D
from sim.errors import ErrorCode, FleetError


@pytest.fixture(scope="module")
def svc() -> Iterator[FleetService]:
    s = FleetService(FleetConfig(world="empty", seed=1))
    s.spawn_robot("r1", Pose2D(0.0, 0.0, 0.0))
    s.spawn_robot("r2", Pose2D(2.0, 0.0, 0.0))
    yield s
    s.close()


def _refused(fn: object, *args: object, code: ErrorCode = ErrorCode.INVALID_ARGUMENT, **kw: object) -> FleetError:
    with pytest.raises(FleetError) as e:
        fn(*args, **kw)  # type: ignore[operator]
    assert e.value.code is code, e.value
    return e.value


def test_every_registered_task_type_has_a_params_model() -> None:
    assert set(task_params.PARAMS) == set(task_types())
    for name, model in task_params.PARAMS.items():
        assert model.model_config.get("extra") == "forbid", name
        assert "navigation" in model.model_fields, name  # missions add the robot's navigator settings to each


def test_unknown_types_and_fields_name_the_valid_ones(svc: FleetService) -> None:
    e = _refused(svc.submit_task, "teleport", "r1", {})
    assert "go_to" in e.message + e.hint and "cover_area" in e.message + e.hint
    e = _refused(svc.submit_task, "go_to", "r1", {"goal": {"x": 1, "y": 1}, "speed": 2})
    assert "speed" in e.message and "goal, align_yaw" in e.hint
    e = _refused(svc.submit_task, "follow_robot", "r1", {"target": "r2", "distance": 0})
    assert "distance" in e.message
    e = _refused(svc.submit_task, "go_to", "r1", {"goal": {"x": 1, "y": 1}, "navigation": {"plannr": {}}})
    assert "plannr" in e.message
    e = _refused(svc.queue_task, "go_to", {"goal": [1, 1], "goal2": 3})
    assert "goal2" in e.message
    e = _refused(svc.assign_tasks, [{"type": "go_to", "params": {"goal": [1, 1]}}, {"type": "go_to", "params": []}],
                 dry_run=True)
    assert "tasks[1].params" in e.message


@pytest.mark.parametrize(("type_name", "params", "field"), [
    ("go_to", {"goal": {"x": float("nan"), "y": 0}}, "goal.x"),
    ("go_to", {"goal": [1e308, 0]}, "goal.x"),
    ("wait", {"seconds": float("inf")}, "seconds"),
    ("wait", {"seconds": 1e9}, "seconds"),
    ("dock_and_charge", {"target_soc": 1.5}, "target_soc"),
    ("follow_waypoints", {"waypoints": [[0, 0]], "rounds": 0}, "rounds"),
    ("follow_waypoints", {"waypoints": [[0, 0]] * 501}, "waypoints"),
    ("follow_waypoints", {"waypoints": [{"x": 0, "y": 0, "dwell_s": -1}]}, "dwell_s"),
    ("cover_area", {"polygon": [[0, 0], [1, 0], [1, 1]], "pattern": "zigzag"}, "pattern"),
    ("sync", {"barrier": "b", "timeout_s": 0}, "timeout_s"),
])
def test_numbers_are_finite_and_bounded_per_type(svc: FleetService, type_name: str, params: dict[str, object],
                                                 field: str) -> None:
    e = _refused(svc.submit_task, type_name, "r1", params)
    assert field in e.message and type_name in e.message


def test_world_checks_apply_to_typed_params(svc: FleetService) -> None:
    e = _refused(svc.submit_task, "go_to", "r1", {"goal": [500, 0]}, code=ErrorCode.OUT_OF_BOUNDS)
    assert "go_to params.goal" in e.message
    e = _refused(svc.queue_task, "follow_waypoints", {"waypoints": [[0, 0], [0, 900]]}, code=ErrorCode.OUT_OF_BOUNDS)
    assert "waypoints[1]" in e.message
    # coverage lanes are counted at the pass spacing tool_width·(1 − overlap): a 150 m square at tool 0.05 m is
    # 3000 lanes without overlap, 6000 at overlap 0.5, 30000 at 0.9 (over MAX_COVERAGE_LANES = 20000)
    square, bounds = [[-75, -75], [75, -75], [75, 75], [-75, 75]], (-100.0, -100.0, 100.0, 100.0)
    assert 150 / (0.05 * (1 - 0.5)) <= MAX_COVERAGE_LANES < 150 / (0.05 * (1 - 0.9))
    task_params.check("cover_area", {"polygon": square, "tool_width": 0.05, "overlap": 0.5}, bounds)
    e = _refused(task_params.check, "cover_area", {"polygon": square, "tool_width": 0.05, "overlap": 0.9}, bounds)
    assert "30000 coverage lanes" in e.message


def test_python_values_are_read_as_the_schema_says(svc: FleetService) -> None:
    """A Pose2D or [x, y(, yaw)] is read as {x, y(, yaw)}; only the keys given are passed on (defaults stay the
    task's)."""
    t = svc.submit_task("go_to", "r1", {"goal": Pose2D(1.0, 2.0, 0.5)})
    assert t["params"] == {"goal": {"x": 1.0, "y": 2.0, "yaw": 0.5}}
    t = svc.submit_task("follow_waypoints", "r2", {"waypoints": [[1, 0], [1, 1, 0.3]], "mode": "loop"})
    assert t["params"] == {"waypoints": [{"x": 1.0, "y": 0.0}, {"x": 1.0, "y": 1.0, "yaw": 0.3}], "mode": "loop"}
    for tid in (t["id"],):
        svc.cancel_task(tid)
