"""MCAP recordings: read back with the `mcap` library, they have the Foxglove channels and the message counts
the run implies; scans decode to what the robot saw; a replay re-drives the world onto the recorded poses;
two runs diff as identical or not; the live view serves the same channels over a WebSocket."""

import json
import socket
from pathlib import Path

import pytest
from mcap.reader import make_reader

from fleet import FleetConfig, FleetService
from fleet.live_view import LiveView
from fleet.missions.batch import RunRequest, run_file
from fleet.recording import channel_counts, diff_runs, replay, states
from sim import Pose2D, default_robot_path, load_robot_spec
from slam import read_mcap_scans

MISSION = """
name: rec
world: robot_arena
seed: 4
time_limit: 6
end_when: time_limit
robots:
  - {name: r1, spawn: spawn_start}
  - {name: r2, pose: {x: -5.0, y: -3.2, yaw: 0.0}}
tasks:
  - {id: go, robot: r1, type: go_to, params: {goal: {x: -2.5, y: -5.0}}}
events:
  - {at: 2.0, type: spawn_obstacle, name: crate, pose: {x: -5.0, y: -4.1}, size: [0.4, 0.4, 1.0]}
recording: {markers_hz: 2, camera_robot: r1, camera_hz: 1}
assertions: [{type: no_collisions}]
"""


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    d = tmp_path_factory.mktemp("rec")
    (d / "rec.yaml").write_text(MISSION)
    return run_file(RunRequest(str(d / "rec.yaml"), None, str(d / "out")))


def test_recording_has_the_foxglove_channels_and_counts(run):
    counts = channel_counts(run.out_dir / "recording.mcap")
    ticks = 60  # 6 s at control_hz 10, one message per tick
    expected = {
        "/map": ("foxglove.Grid", 2),  # at start and after the crate appeared
        "/tf": ("foxglove.FrameTransforms", ticks),
        "/r1/pose": ("foxglove.PoseInFrame", ticks), "/r2/pose": ("foxglove.PoseInFrame", ticks),
        "/r1/scan": ("foxglove.LaserScan", ticks), "/r2/scan": ("foxglove.LaserScan", ticks),  # lidar at 10 Hz
        "/markers": ("foxglove.SceneUpdate", 12),  # every 0.5 s from the first tick
        "/r1/camera": ("foxglove.CompressedImage", 6),  # 1 Hz
        "/fleetnav/state": ("fleetnav.State", ticks),
        "/events": ("foxglove.Log", sum(run.report["metrics"]["events"].values())),
    }
    assert counts == expected
    assert run.report["recording"]["channels"] == {t: n for t, (_, n) in expected.items()}


def test_mcap_metadata_carries_the_mission_and_spawn_poses(run):
    with (run.out_dir / "recording.mcap").open("rb") as f:
        meta = {m.name: m.metadata for m in make_reader(f).iter_metadata()}
    assert meta["fleetnav.mission"]["seed"] == "4"
    assert "name: rec" in meta["fleetnav.mission"]["yaml"]
    spawn = json.loads(meta["fleetnav.spawn"]["robots"])
    assert spawn["r1"]["pose"] == [-5.0, -5.0, 0.0] and spawn["r2"]["pose"] == [-5.0, -3.2, 0.0]


def test_recorded_scans_decode_to_what_the_lidar_measured(run):
    scans = list(read_mcap_scans(run.out_dir / "recording.mcap", topic="/r2/scan", robot="r2"))
    beams = load_robot_spec(default_robot_path()).sensors.lidar.beams
    assert len(scans) == 60 and all(len(s.scan.ranges) == beams for s in scans)
    first, last = scans[0].scan, scans[-1].scan
    ahead = lambda s: s.ranges[len(s.ranges) // 2]  # noqa: E731  (beam at angle 0: the robot's heading)
    # r2 stands still facing +x; the crate (0.4 m, centre 0.9 m south) is not ahead, so ahead is unchanged
    assert ahead(first) == pytest.approx(ahead(last), abs=0.05)
    # the beam pointing south (−90°) sees the crate's face after it appears: 0.9 − 0.2 = 0.7 m
    south = lambda s: s.ranges[len(s.ranges) // 4]  # noqa: E731
    assert south(last) == pytest.approx(0.7, abs=0.05) and south(first) > 0.9


def test_state_stream_ends_where_the_report_says(run):
    last = list(states(run.out_dir / "recording.mcap"))[-1]
    assert last["t"] == pytest.approx(6.0)
    i = last["names"].index("r1")
    fp = run.report["metrics"]["robots"]["r1"]["final_pose"]
    assert last["pose"][i][:2] == pytest.approx([fp["x"], fp["y"]], abs=1e-6)


def test_replay_re_drives_the_world_onto_the_recorded_poses(run):
    r = replay(run.out_dir / "recording.mcap")
    assert r.ticks == 60 and r.end_time == pytest.approx(6.0)
    assert set(r.robots) == {"r1", "r2"}
    assert r.max_divergence_m["r1"] < 1e-4  # commands rounded to 1e-6 in the recording
    assert r.max_divergence_m["r2"] < 1e-4


def test_diff_of_two_runs(run, tmp_path):
    assert diff_runs(run.out_dir, run.out_dir).identical
    (tmp_path / "rec.yaml").write_text(MISSION.replace("goal: {x: -2.5", "goal: {x: -3.0"))
    other = run_file(RunRequest(str(tmp_path / "rec.yaml"), None, str(tmp_path / "out")))
    d = diff_runs(run.out_dir, other.out_dir)
    assert not d.identical
    assert d.trajectories["r1"] > 0.1 and d.trajectories["r2"] == 0.0
    assert any(m["key"].startswith("metrics.robots.r1") for m in d.metrics)


def test_recording_off_writes_no_mcap(tmp_path):
    (tmp_path / "m.yaml").write_text(MISSION.replace("recording: {markers_hz: 2, camera_robot: r1, camera_hz: 1}",
                                                     "recording: {enabled: false}").replace("time_limit: 6",
                                                                                            "time_limit: 2.5"))
    out = run_file(RunRequest(str(tmp_path / "m.yaml"), None, str(tmp_path / "o")))
    assert not (tmp_path / "o" / "recording.mcap").exists()
    assert out.report["recording"]["channels"] == {}


def test_live_view_serves_a_running_service():
    svc = FleetService(FleetConfig(world="empty"))
    try:
        svc.spawn_robot("r1", Pose2D(0, 0, 0))
        view = LiveView(port=0).attach(svc)
        port = int(view.url.rsplit(":", 1)[1])
        assert port > 0
        with socket.create_connection(("127.0.0.1", port), timeout=5):
            pass  # the WebSocket server accepts connections
        svc.advance(0.5)
        assert view._publisher is not None and view._publisher.counts["/fleetnav/state"] == 5
        view.close()
    finally:
        svc.close()


def test_reader_refuses_what_is_not_a_recording(tmp_path):
    from sim.errors import FleetError

    bad = tmp_path / "x.mcap"
    bad.write_bytes(b"not an mcap file")
    with pytest.raises(FleetError):
        channel_counts(bad)
    with pytest.raises(FleetError, match="no recording"):
        channel_counts(Path(tmp_path / "missing.mcap"))


def test_foxglove_layout_file_is_current_and_shows_the_channels():
    """Regenerate with fleet.recording.layout.write_layout (robot names of the shipped missions, camera r1)."""
    from fleet.missions import load_mission
    from fleet.recording.layout import build_layout

    root = Path(__file__).resolve().parents[2]
    names: list[str] = []
    for f in sorted((root / "configs" / "missions").glob("*.yaml")):
        names += [n for n in load_mission(f).robot_names() if n not in names]
    on_disk = json.loads((root / "configs" / "foxglove_layout.json").read_text())
    assert on_disk == json.loads(build_layout(names, "r1").to_json())
    text = json.dumps(on_disk)
    for topic in ("/map", "/markers", "/events", "/fleetnav/state", "/r1/camera", *(f"/{n}/scan" for n in names)):
        assert f'"{topic}"' in text, topic
