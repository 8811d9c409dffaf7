"""Coverage paths: the closed-form number of passes, ≥ 99 % coverage, holes split cells, and the navigator
drives a coverage path to the end."""

from __future__ import annotations

import math

import numpy as np
import pytest
from shapely.geometry import LineString, Polygon

from planning.coverage import coverage_stats, plan_coverage
from planning.nav_types import NavState
from sim.errors import FleetError
from sim.types import Pose2D, WorldDescription
from tests.planning.test_navigator import TinyRobot, hall_boxes, navigator
from tests.planning.worlds import walls


@pytest.mark.parametrize(("width", "tool", "overlap"), [(5.0, 0.5, 0.1), (4.3, 0.5, 0.1), (3.0, 0.4, 0.0),
                                                        (2.0, 0.6, 0.25), (0.6, 0.5, 0.1)])
def test_rectangle_passes_match_the_closed_form(width, tool, overlap):
    # lanes along the long side (10 m); across the width W the centre line spans W − w, lanes ≤ w(1 − o) apart
    plan = plan_coverage([(0, 0), (10, 0), (10, width), (0, width)], tool_width=tool, overlap=overlap)
    expected = max(1, math.ceil((width - tool) / (tool * (1 - overlap)) - 1e-9) + 1)
    assert plan.passes == expected and plan.cells == 1
    assert plan.coverage_pct >= 99.0
    ys = sorted({round(float(s[0, 1]), 6) for s in plan.swaths})
    assert ys[0] == pytest.approx(tool / 2, abs=1e-5) and ys[-1] == pytest.approx(width - tool / 2, abs=1e-5)
    assert np.diff(ys).max(initial=0) <= tool * (1 - overlap) + 1e-9  # spacing never above the requested
    for s in plan.swaths:  # every pass runs the full length, inside the region by half a tool
        assert abs(s[0, 0] - s[1, 0]) == pytest.approx(10 - tool, abs=1e-5)


def test_path_length_and_overlap_figure_for_a_rectangle():
    # 11 passes of 9.5 m joined by 10 turns of 0.45 m; overlap % = (L·w − swept area) / swept area
    plan = plan_coverage([(0, 0), (10, 0), (10, 5), (0, 5)], tool_width=0.5, overlap=0.1)
    length = 11 * 9.5 + 10 * 0.45
    assert plan.length == pytest.approx(length, abs=1e-4)
    swept = LineString(plan.path).buffer(0.25).area
    assert 49.5 < swept < 50.0  # the disc tool misses only slivers at the lane ends
    assert plan.overlap_pct == pytest.approx(100 * (length * 0.5 - swept) / swept, abs=1e-3)


def test_rotated_rectangle_sweeps_along_its_long_side():
    a = math.radians(30)
    c, s = math.cos(a), math.sin(a)
    rect = [(0, 0), (8 * c, 8 * s), (8 * c - 3 * s, 8 * s + 3 * c), (-3 * s, 3 * c)]
    plan = plan_coverage(rect, tool_width=0.5, overlap=0.0)
    assert plan.passes == math.ceil((3 - 0.5) / 0.5) + 1
    d = plan.swaths[0][1] - plan.swaths[0][0]
    assert abs(math.remainder(math.atan2(d[1], d[0]) - a, math.pi)) < 1e-6
    assert plan.coverage_pct >= 99.0


def test_a_hole_splits_the_sweep_into_cells_and_is_never_entered():
    region = [(0, 0), (10, 0), (10, 6), (0, 6)]
    hole = [(4, 2), (6, 2), (6, 4), (4, 4)]
    plan = plan_coverage(region, holes=[hole], tool_width=0.5, overlap=0.1)
    assert plan.cells == 4  # below, left of, right of and above the hole
    assert plan.coverage_pct >= 99.0
    assert not LineString(plan.path).intersects(Polygon(hole).buffer(0.25 - 1e-5))  # the tool stays off it
    assert Polygon(region).buffer(-0.25 + 1e-5).contains(LineString(plan.path))


def test_spiral_covers_a_region_with_a_hole():
    region = [(0, 0), (10, 0), (10, 6), (0, 6)]
    plan = plan_coverage(region, holes=[[(4, 2), (6, 2), (6, 4), (4, 4)]], tool_width=0.5, overlap=0.1,
                         pattern="spiral")
    assert plan.pattern == "spiral" and plan.coverage_pct >= 98.0
    assert not LineString(plan.path).intersects(Polygon([(4, 2), (6, 2), (6, 4), (4, 4)]).buffer(0.249))
    rect = plan_coverage(region, tool_width=0.5, overlap=0.1, pattern="spiral")
    assert rect.coverage_pct >= 99.0


def test_bad_input_is_a_clear_error():
    square = [(0, 0), (1, 0), (1, 1), (0, 1)]
    with pytest.raises(FleetError, match="not wider than the tool"):
        plan_coverage(square, tool_width=2.0)
    with pytest.raises(FleetError, match="overlap"):
        plan_coverage(square, tool_width=0.2, overlap=1.0)
    with pytest.raises(FleetError, match="tool_width"):
        plan_coverage(square, tool_width=0.0)
    with pytest.raises(FleetError, match="invalid coverage region"):
        plan_coverage([(0, 0), (1, 1), (1, 0), (0, 1)], tool_width=0.2)  # a bow tie
    with pytest.raises(FleetError, match="pattern"):
        plan_coverage(square, tool_width=0.2, pattern="zigzag")  # type: ignore[arg-type]


def test_the_navigator_drives_a_coverage_path_and_covers_the_area():
    # a 5 × 3 m patch inside an empty 10 × 6 m hall, driven by the navigator (approach, then the route)
    region = Polygon([(3, 1.5), (8, 1.5), (8, 4.5), (3, 4.5)])
    plan = plan_coverage(region, tool_width=0.6, overlap=0.15)
    world = WorldDescription("hall", models=tuple(walls(0, 0, 10, 6)))
    nav = navigator(world, controller="mpc_osqp")
    robot = TinyRobot(Pose2D(1.0, 1.0, 0.0), hall_boxes())
    nav.follow_route(plan.path, 0.0)
    trace = []
    for _ in range(4000):
        robot.step(nav.tick(robot.t, robot.pose, (robot.v, robot.w), robot.scan()), 0.05)
        trace.append((robot.pose.x, robot.pose.y))
        if nav.state.done:
            break
    st = nav.status()
    assert st.state is NavState.SUCCEEDED, st.reason
    driven, _ = coverage_stats(np.array(trace), region, plan.tool_width)
    assert driven >= 97.0  # the tracked path, not just the planned one, covers the patch
