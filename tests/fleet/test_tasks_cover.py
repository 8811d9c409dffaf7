"""cover_area: the robot actually sweeps the polygon; the coverage it reports is checked against shapely on
the trajectory recorded independently from the snapshots."""

import pytest
from shapely.geometry import LineString, Polygon

from fleet import FleetConfig, FleetError, FleetService
from sim import Pose2D

RECT = [(-3.0, -3.0), (0.0, -3.0), (0.0, -1.0), (-3.0, -1.0)]


@pytest.fixture()
def svc():
    s = FleetService(FleetConfig(world="empty"))
    s.spawn_robot("r1", Pose2D(-3.5, -3.5, 0.0))
    yield s
    s.close()


def drive_and_record(s, task_id, limit_s):
    trace, t = [], 0.0
    while t < limit_s:
        s.advance(0.1)
        t += 0.1
        p = s.robot("r1").pose
        trace.append((p.x, p.y))
        if s.task_status(task_id)["state"] not in ("queued", "active"):
            break
    return s.task_status(task_id), trace


def swept_pct(trace, region, tool):
    return 100.0 * LineString(trace).buffer(tool / 2).intersection(region).area / region.area


def test_cover_rectangle_reports_the_coverage_it_achieved(svc):
    task = svc.cover_area("r1", RECT, tool_width=0.5)
    st, trace = drive_and_record(svc, task["id"], 90)
    assert st["state"] == "succeeded"
    truth = swept_pct(trace, Polygon(RECT), 0.5)
    assert truth > 90.0  # the robot really swept the region
    assert st["progress"]["coverage_pct"] == pytest.approx(truth, abs=2.0)
    assert st["progress"]["passes"] == 5  # ceil((2 − 0.5) / (0.5 · 0.9)) + 1 lanes across the 2 m side


def test_cover_with_a_hole_leaves_the_hole_out(svc):
    hole = [(-2.0, -2.4), (-1.0, -2.4), (-1.0, -1.6), (-2.0, -1.6)]
    region = Polygon(RECT, [hole])
    task = svc.cover_area("r1", RECT, holes=[hole], tool_width=0.5)
    st, trace = drive_and_record(svc, task["id"], 120)
    assert st["state"] == "succeeded"
    assert swept_pct(trace, region, 0.5) == pytest.approx(st["progress"]["coverage_pct"], abs=2.0)
    assert st["progress"]["coverage_pct"] > 80.0
    # the planned path keeps the tool out of the hole: the robot never drove through its middle
    assert not any(Polygon(hole).buffer(-0.3).contains(LineString(trace[i:i + 2]).centroid)
                   for i in range(len(trace) - 1))


def test_unmet_min_coverage_fails_with_the_figure(svc):
    task = svc.cover_area("r1", RECT, tool_width=0.5, min_coverage_pct=99.9)
    st, _ = drive_and_record(svc, task["id"], 90)
    assert st["state"] == "failed"
    assert "min_coverage_pct 99.9" in st["reason"]


@pytest.mark.parametrize("polygon", [[(0, 0), (1, 0)], [(0, 0), (1, 1), (1, 0), (0, 1)], "square"])
def test_bad_polygons_fail_at_submit(svc, polygon):
    with pytest.raises(FleetError) as err:
        svc.submit_task("cover_area", "r1", {"polygon": polygon})
    assert err.value.code.value == "INVALID_ARGUMENT"
