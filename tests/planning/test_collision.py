"""FclWorld distances and collisions against closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planning.collision import FclWorld
from sim.errors import FleetError
from sim.types import Pose2D, WorldDescription
from tests.planning.worlds import box, cylinder


def _world(*models) -> FclWorld:
    return FclWorld(WorldDescription("t", models=tuple(models)))


def test_round_robot_distance_to_box_face_and_cylinder() -> None:
    fw = _world(box("b", 2.0, 0.0, 1.0, 1.0), cylinder("c", 0.0, 3.0, 0.5))
    r = 0.3
    assert fw.min_distance(Pose2D(0.0, 0.0), r) == pytest.approx(2.0 - 0.5 - r, abs=1e-6)
    assert fw.min_distance(Pose2D(0.0, 1.9), r) == pytest.approx(3.0 - 1.9 - 0.5 - r, abs=1e-6)
    assert not fw.footprint_collides(Pose2D(1.0, 0.0), r)  # 0.2 m gap
    assert fw.footprint_collides(Pose2D(1.25, 0.0), r)
    assert fw.min_distance(Pose2D(1.25, 0.0), r) == 0.0
    assert fw.colliding_models(Pose2D(1.25, 0.0), r) == ["b"]


def test_polygon_footprint_turns_with_the_robot() -> None:
    fw = _world(box("wall", 1.0, 0.0, 0.2, 4.0))  # face at x = 0.9
    rect = [(0.5, 0.2), (-0.5, 0.2), (-0.5, -0.2), (0.5, -0.2)]  # 1.0 × 0.4 m
    assert fw.min_distance(Pose2D(0.0, 0.0, 0.0), rect) == pytest.approx(0.4, abs=1e-6)
    assert fw.min_distance(Pose2D(0.0, 0.0, math.pi / 2), rect) == pytest.approx(0.7, abs=1e-6)
    assert fw.footprint_collides(Pose2D(0.5, 0.0, 0.0), rect)
    assert not fw.footprint_collides(Pose2D(0.5, 0.0, math.pi / 2), rect)


def test_obstacles_outside_the_height_slab_are_ignored() -> None:
    fw = _world(box("shelf", 0.0, 0.0, 1.0, 1.0, h=0.3, z0=1.2))
    assert len(fw) == 0
    assert not fw.footprint_collides(Pose2D(0.0, 0.0), 0.3)


def test_path_min_distance_samples_the_whole_polyline() -> None:
    fw = _world(cylinder("c", 1.0, 0.0, 0.2))
    path = np.array([[0.0, 1.0], [2.0, 1.0], [2.0, -1.0]])
    assert fw.path_min_distance(path, 0.1, step=0.01) == pytest.approx(1.0 - 0.2 - 0.1, abs=1e-6)
    assert fw.path_min_distance(np.array([[0.0, 0.0], [2.0, 0.0]]), 0.1) == 0.0


def test_bad_footprints_are_rejected() -> None:
    fw = _world(cylinder("c", 1.0, 0.0, 0.2))
    with pytest.raises(FleetError):
        fw.min_distance(Pose2D(), -0.1)
    with pytest.raises(FleetError):
        fw.min_distance(Pose2D(), [(0.0, 0.0), (1.0, 0.0)])
