"""Mission files: a malformed one is an error naming the file, the line and the field; references between
sections are checked against the mission and its world; the JSON Schema for editors is current."""

import json
from pathlib import Path

import pytest

from fleet.missions import ASSERTIONS, EVENTS, json_schema, load_mission, validate_files
from fleet.missions.registry import Registry
from fleet.missions.schema import Mission
from sim.config import StrictModel
from sim.errors import FleetError

ROOT = Path(__file__).resolve().parents[2]
GOOD = """\
name: t
world: robot_arena
time_limit: 20
robots:
  - name: r1
    spawn: spawn_start
tasks:
  - id: go
    robot: r1
    type: go_to
    params: {goal: {x: 1.0, y: 1.0}}
events:
  - at: 5
    type: estop
    robot: r1
assertions:
  - type: reach_goal
    robot: r1
    task: go
    within: 15
"""


def error_for(tmp_path, text):
    path = tmp_path / "m.yaml"
    path.write_text(text)
    with pytest.raises(FleetError) as exc:
        load_mission(path)
    assert exc.value.code == "INVALID_CONFIG"
    return exc.value.message, str(path)


def test_the_good_mission_loads(tmp_path):
    path = tmp_path / "m.yaml"
    path.write_text(GOOD)
    m = load_mission(path)
    assert m.robot_names() == ["r1"] and m.task_keys() == ["go"]
    assert Path(m.world).name == "robot_arena.world"


@pytest.mark.parametrize(("old", "new", "line", "field", "says"), [
    ("time_limit: 20", "tme_limit: 20", 3, "tme_limit", "Extra inputs are not permitted"),
    ("time_limit: 20", "time_limit: soon", 3, "time_limit", "valid number"),
    ("    within: 15", "    within: -1", 20, "assertions.0.within", "greater than 0"),
    ("    within: 15", "    within: 15\n    tolerence: 0.2", 21, "assertions.0.tolerence", "Extra inputs"),
    ("    robot: r1\n    task: go", "    robot: r9\n    task: go", 18, "assertions.0.robot", "unknown robot 'r9'"),
    ("    task: go\n", "    task: gone\n", 19, "assertions.0.task", "unknown task key 'gone'"),
    ("    spawn: spawn_start", "    spawn: dock_9", 6, "robots.0.spawn", "spawn points: spawn_start"),
    ("    type: go_to", "    type: teleport", 10, "tasks.0.type", "valid: "),
    ("  - at: 5", "  - at: 25", 13, "events.0.at", "after the time limit"),
    ("    type: estop", "    type: explode", 13, "events.0", "expected tags"),
    ("world: robot_arena", "world: atlantis", 2, "world", "no world 'atlantis'"),
])
def test_malformed_mission_names_file_line_and_field(tmp_path, old, new, line, field, says):
    assert old in GOOD
    msg, path = error_for(tmp_path, GOOD.replace(old, new, 1))
    assert f"{path}:{line}: field '{field}'" in msg
    assert says in msg


def test_unknown_assertion_type_lists_the_valid_ones(tmp_path):
    msg, path = error_for(tmp_path, GOOD.replace("  - type: reach_goal", "  - type: reach_gaol"))
    assert f"{path}:17: field 'assertions.0'" in msg
    for name in ASSERTIONS.names():
        assert f"'{name}'" in msg


def test_yaml_syntax_error_names_line_and_column(tmp_path):
    msg, path = error_for(tmp_path, GOOD.replace("params: {goal: {x: 1.0, y: 1.0}}", "params: {goal: {x: 1.0, y: 1.0}"))
    assert msg.startswith(f"{path}:12:") and "malformed YAML" in msg


def test_several_problems_are_reported_together(tmp_path):
    msg, _ = error_for(tmp_path, GOOD.replace("    robot: r1\n    type: go_to", "    robot: r7\n    type: go_to")
                       .replace("    robot: r1\n    task: go", "    robot: r8\n    task: go"))
    assert "unknown robot 'r7'" in msg and "unknown robot 'r8'" in msg


def test_fleet_robots_are_named_as_spawn_fleet_names_them(tmp_path):
    text = GOOD.replace("robots:\n  - name: r1\n    spawn: spawn_start\n",
                        "robots:\n  - name: r1\n    spawn: spawn_start\n  - name: bot2\n    pose: {x: 0, y: 0}\n"
                        "fleets:\n  - {count: 3, prefix: bot}\n")
    path = tmp_path / "m.yaml"
    path.write_text(text)
    assert load_mission(path).robot_names() == ["r1", "bot2", "bot1", "bot3", "bot4"]


def test_a_mission_needs_robots_and_assertions(tmp_path):
    msg, path = error_for(tmp_path, "name: t\nworld: empty\ntime_limit: 5\nassertions: []\n")
    assert f"{path}:4: field 'assertions'" in msg and "at least 1 item" in msg
    msg, path = error_for(tmp_path, "name: t\nworld: empty\ntime_limit: 5\nassertions: [{type: no_collisions}]\n")
    assert "a mission needs robots or fleets" in msg


def test_shipped_missions_validate():
    files = sorted((ROOT / "configs" / "missions").glob("*.yaml"))
    assert len(files) >= 6
    assert [err for _, err in validate_files(files)] == [None] * len(files)


def test_json_schema_file_is_current():
    """Regenerate with: python -c "from fleet.missions import write_json_schema;
    write_json_schema('configs/missions/mission.schema.json')" """
    on_disk = json.loads((ROOT / "configs" / "missions" / "mission.schema.json").read_text())
    assert on_disk == json.loads(json.dumps(json_schema())), "configs/missions/mission.schema.json is stale"


def test_schema_offers_every_registered_type():
    schema = json_schema()
    assert set(schema["properties"]["assertions"]["items"]["discriminator"]["mapping"]) == set(ASSERTIONS.names())
    assert set(schema["properties"]["events"]["items"]["discriminator"]["mapping"]) == set(EVENTS.names())
    assert schema["additionalProperties"] is False  # extra="forbid" reaches editors too
    assert Mission.model_config["extra"] == "forbid"


def test_registry_refuses_a_second_registration_and_lists_names():
    reg: Registry = Registry("widget")

    class W(StrictModel):
        type: str = "w"

    reg.register("w", W)(lambda: None)
    with pytest.raises(ValueError, match="already registered"):
        reg.register("w", W)(lambda: None)
    with pytest.raises(FleetError, match="known widgets: w"):
        reg.get("v")


def test_traffic_defaults_are_the_layers_but_speed() -> None:
    """A mission without a `traffic:` key runs the layer as tuned (e.g. urgent_s 10 s since the twelfth landing);
    `speed` is the one documented difference (missions 0.6 m/s, the Python API 0.45)."""
    import inspect

    from fleet.missions.schema import TrafficSection
    from fleet.traffic.manager import TrafficManager

    section = TrafficSection.model_validate({})
    params = inspect.signature(TrafficManager.__init__).parameters
    differ = {k: (v, params[k].default) for k, v in section.model_dump(exclude={"type"}).items()
              if v != params[k].default}
    assert differ == {"speed": (0.6, 0.45)}, differ
    assert section.urgent_s == 10.0


def test_every_traffic_key_is_a_layer_setting_and_bad_values_are_named() -> None:
    from fleet.missions.schema import TrafficSection
    from fleet.traffic.layer import SETTINGS

    section = TrafficSection.model_validate({"urgent_rank": "since_urgent", "congestion": 4})
    keys = set(section.model_dump(exclude={"type"}))
    assert keys <= set(SETTINGS), sorted(keys - set(SETTINGS))
    assert set(SETTINGS) - keys == {"seed"}  # and every layer setting but its RNG seed is a key
    assert section.urgent_cells == 3 and section.withdraw == "crowded"  # the layer's defaults
    assert section.urgent_rank == "since_urgent" and section.congestion == 4
    with pytest.raises(ValueError, match="urgent_rank"):
        TrafficSection.model_validate({"urgent_rank": "oldest"})
    with pytest.raises(ValueError, match="congestion"):
        TrafficSection.model_validate({"congestion": -1})
    assert TrafficSection.model_validate({"withdraw": "flush", "flush_s": 2}).withdraw == "flush"
    with pytest.raises(ValueError, match="withdraw"):
        TrafficSection.model_validate({"withdraw": "all"})
