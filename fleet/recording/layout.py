"""The Foxglove layout for fleetnav recordings and the live view (built with foxglove-sdk's layout types).

A 3D panel on the map frame (map grid, every robot's scan, poses, markers: robots, planned paths, goals,
collisions), a camera image panel, the event log and the raw fleet state. Topics are per robot namespace,
so the layout lists the robots it should show; configs/foxglove_layout.json is built for the robot names
the shipped missions use (regenerate with `write_layout`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import foxglove.layouts as fl

from fleet.recording.types import STATE_TOPIC


def build_layout(robots: Sequence[str], camera_robot: str | None = None) -> fl.Layout:
    topics: dict[str, fl.BaseRendererTopicSettings] = {
        "/map": fl.BaseRendererGridTopicSettings(visible=True, color_mode="gradient", gradient=("#ffffff", "#000000"),
                                                 min_value=0, max_value=100),
        "/markers": fl.BaseRendererSceneUpdateTopicSettings(visible=True),
    }
    for r in robots:
        topics[f"/{r}/scan"] = fl.BaseRendererLaserScanTopicSettings(visible=True, point_size=3, color_mode="flat",
                                                                      flat_color="#e53935")
        topics[f"/{r}/pose"] = fl.BaseRendererPoseTopicSettings(visible=False)
    scene = fl.ThreeDeePanel(title="map, robots, scans, paths",
                             config=fl.ThreeDeeConfig(follow_tf="map", fixed_frame="map", topics=topics))
    camera = fl.ImagePanel(title="camera", config=fl.ImageConfig(image_mode=fl.ImageModeConfig(
        image_topic=f"/{camera_robot or robots[0]}/camera")))
    side = fl.SplitContainer(direction="column", items=[
        fl.SplitItem(proportion=1, content=camera),
        fl.SplitItem(proportion=1, content=fl.LogPanel(title="events", config=fl.LogConfig(topic_to_render="/events"))),
        fl.SplitItem(proportion=1, content=fl.RawMessagesPanel(config=fl.RawMessagesConfig(topic_path=STATE_TOPIC))),
    ])
    return fl.Layout(content=fl.SplitContainer(direction="row", items=[fl.SplitItem(proportion=2, content=scene),
                                                                        fl.SplitItem(proportion=1, content=side)]))


def write_layout(path: str | Path, robots: Sequence[str], camera_robot: str | None = None) -> Path:
    import json

    p = Path(path)
    p.write_text(json.dumps(json.loads(build_layout(robots, camera_robot).to_json()), indent=2) + "\n",
                 encoding="utf-8")
    return p
