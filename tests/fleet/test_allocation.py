"""The allocators on problems with known answers: brute force over permutations, closed-form ETAs, charge
stops and time windows. Pure: straight-line travel, no world."""

import itertools
import math

import numpy as np
import pytest

from fleet.allocation import Energy, EuclideanTravel, RobotInput, TaskRequest, allocate
from fleet.tasks.types import WorkProfile

NO_DRAIN = Energy(capacity_wh=100.0, drive_wh_per_m=0.0, idle_w=0.0, charge_w=200.0, reserve=0.0, charge_to=0.9)
METHODS = ("hungarian", "hungarian_rounds", "auction", "greedy")


def robots_at(xy, soc=1.0, speed=1.0):
    return [RobotInput(f"r{i}", float(x), float(y), soc, speed) for i, (x, y) in enumerate(xy)]


def goto(i, x, y, **kw):
    return TaskRequest(f"q{i}", "go_to", {"goal": {"x": x, "y": y}}, WorkProfile((x, y), (x, y)), **kw)


def tasks_at(xy):
    return [goto(i, float(x), float(y)) for i, (x, y) in enumerate(xy)]


def run(method, robots, tasks, docks=None, energy=NO_DRAIN, now=0.0):
    return allocate(method, now, robots, tasks, docks or {}, EuclideanTravel(), energy)


def optimal_routes(robots, goals):
    """Brute force: every split of the goals among robots, every order within each robot's route."""
    best = math.inf
    for owner in itertools.product(range(len(robots)), repeat=len(goals)):
        total = 0.0
        for r, start in enumerate(robots):
            mine = [g for g, o in zip(goals, owner, strict=True) if o == r]
            total += min(sum(math.dist(a, b) for a, b in itertools.pairwise([start, *order]))
                         for order in itertools.permutations(mine))
        best = min(best, total)
    return best


@pytest.mark.parametrize("seed", range(12))
def test_hungarian_matches_brute_force_when_each_robot_gets_at_most_one_task(seed):
    rng = np.random.default_rng(seed)
    n_r, n_t = 4, int(rng.integers(2, 5))
    rxy, gxy = rng.uniform(-10, 10, (n_r, 2)), rng.uniform(-10, 10, (n_t, 2))
    brute = min(sum(math.dist(rxy[p[t]], gxy[t]) for t in range(n_t))
                for p in itertools.permutations(range(n_r), n_t))
    a = run("hungarian", robots_at(rxy), tasks_at(gxy))
    assert len(a.assignments) == n_t and not a.infeasible
    assert a.travel_m == pytest.approx(brute, rel=1e-9)
    assert len({x.robot for x in a.assignments}) == n_t  # one task each


@pytest.mark.parametrize("seed", range(8))
def test_every_method_is_at_least_optimal_and_the_auction_within_twice_it(seed):
    rng = np.random.default_rng(100 + seed)
    rxy, gxy = rng.uniform(-10, 10, (2 + seed % 2, 2)), rng.uniform(-10, 10, (5, 2))
    opt = optimal_routes([tuple(p) for p in rxy], [tuple(p) for p in gxy])
    runs = {m: run(m, robots_at(rxy), tasks_at(gxy)) for m in METHODS}
    cost = {m: a.travel_m for m, a in runs.items()}
    assert all(c >= opt - 1e-9 for c in cost.values())  # no allocator can beat the optimum
    assert all(a.travel_lower_bound_m <= opt + 1e-9 for a in runs.values())  # the bound is a bound
    assert cost["auction"] <= 2.0 * opt  # SSI MiniSum bound (Lagoudakis et al. 2005)


def test_travel_is_the_sum_of_the_legs_each_robot_drives():
    rxy, gxy = [(0.0, 0.0), (10.0, 0.0)], [(1.0, 0.0), (2.0, 0.0), (9.0, 0.0), (8.0, 0.0), (3.0, 0.0)]
    for m in METHODS:
        a = run(m, robots_at(rxy), tasks_at(gxy))
        legs = 0.0
        for r in ("r0", "r1"):
            steps = sorted((x for x in a.assignments if x.robot == r), key=lambda x: x.order)
            pts = [rxy[int(r[1])]] + [tuple(x.path[-1]) for x in steps]
            legs += sum(math.dist(p, q) for p, q in itertools.pairwise(pts))
        assert a.travel_m == pytest.approx(legs)
    assert run("auction", robots_at(rxy), tasks_at(gxy)).travel_m == pytest.approx(5.0)  # 0→1→2→3, 10→9→8


def test_eta_is_distance_over_speed_and_waits_for_the_window():
    robot = robots_at([(0.0, 0.0)], speed=0.5)
    a = run("hungarian", robot, [goto(0, 3.0, 4.0)], now=100.0)
    assert a.assignments[0].finish == pytest.approx(100.0 + 5.0 / 0.5)
    late = run("hungarian", robot, [goto(0, 3.0, 4.0, earliest_start=130.0)], now=100.0)
    # the task is held until its window opens (the robot waits where it is), then it drives
    assert late.assignments[0].begin == pytest.approx(130.0)
    assert late.assignments[0].finish == pytest.approx(140.0)
    assert late.makespan_s == pytest.approx(40.0)


@pytest.mark.parametrize("method", METHODS)
def test_infeasible_time_windows_are_reported_not_dropped(method):
    tasks = [goto(0, 1.0, 0.0), goto(1, 2.0, 0.0, earliest_start=50.0, deadline=40.0),
             goto(2, 30.0, 0.0, deadline=10.0)]
    a = run(method, robots_at([(0.0, 0.0)]), tasks)
    assert [x.request for x in a.assignments] == ["q0"]
    why = {i.request: i.reason for i in a.infeasible}
    assert set(why) == {"q1", "q2"}
    assert why["q1"].startswith("empty time window")
    assert why["q2"].startswith("deadline 10.0 s") and "30.0 s" in why["q2"]  # 30 m at 1 m/s


def test_deadline_met_only_by_the_robot_that_is_free_is_reported_as_busy():
    tasks = [goto(0, 5.0, 0.0, priority=1), goto(1, 0.0, 5.0, deadline=6.0)]
    a = run("hungarian", robots_at([(0.0, 0.0)]), tasks)  # the high-priority task goes first: 5 + 10 m late
    assert [x.request for x in a.assignments] == ["q0"]
    assert "busy" in a.infeasible[0].reason


@pytest.mark.parametrize("method", METHODS)
def test_higher_priority_goes_first_even_when_farther(method):
    tasks = [goto(0, 1.0, 0.0), goto(1, -8.0, 0.0, priority=5)]
    a = run(method, robots_at([(0.0, 0.0)]), tasks)
    order = [x.request for x in sorted(a.assignments, key=lambda x: x.order)]
    assert order == ["q1", "q0"]


DRAIN = Energy(capacity_wh=10.0, drive_wh_per_m=0.1, idle_w=0.0, charge_w=100.0, reserve=0.2, charge_to=0.9)


@pytest.mark.parametrize("method", METHODS)
def test_robot_too_low_gets_a_charge_stop_first(method):
    # 0.01 soc per metre: 5 m from 0.22 would leave 0.17 < 0.2 reserve
    robot = robots_at([(0.0, 0.0)], soc=0.22)
    a = run(method, robot, [goto(0, 5.0, 0.0)], docks={"dock_1": (0.0, 3.0)}, energy=DRAIN)
    (x,) = a.assignments
    assert x.charge_dock == "dock_1"
    assert x.travel_m == pytest.approx(3.0 + math.hypot(5.0, 3.0))  # via the dock
    at_dock = 0.22 - 3.0 * 0.01
    assert x.charge_s == pytest.approx((0.9 - at_dock) * 10.0 / 100.0 * 3600.0)
    assert x.soc_after == pytest.approx(0.9 - math.hypot(5.0, 3.0) * 0.01)
    assert x.path[0].tolist() == [0.0, 0.0] and x.path[1].tolist() == [0.0, 3.0]


@pytest.mark.parametrize("method", METHODS)
def test_a_charged_robot_is_preferred_to_a_detour(method):
    robots = [RobotInput("low", 0.0, 0.0, 0.22, 1.0), RobotInput("full", 7.0, 0.0, 1.0, 1.0)]
    a = run(method, robots, [goto(0, 5.0, 0.0)], docks={"dock_1": (0.0, 3.0)}, energy=DRAIN)
    assert a.assignments[0].robot == "full" and a.assignments[0].charge_dock is None


def test_no_dock_and_no_charge_is_reported_as_battery():
    a = run("hungarian", robots_at([(0.0, 0.0)], soc=0.22), [goto(0, 5.0, 0.0)], energy=DRAIN)
    assert not a.assignments
    assert a.infeasible[0].reason.startswith("battery") and "no docks" in a.infeasible[0].reason


def test_unknown_method_lists_the_methods():
    from fleet import FleetError

    with pytest.raises(FleetError) as err:
        run("simplex", robots_at([(0, 0)]), tasks_at([(1, 1)]))
    assert all(m in err.value.hint for m in METHODS)


def test_lower_bound_is_tight_when_the_optimum_is_a_set_of_chains():
    # robots at both ends of a line of goals: the optimal routes are the assignment optimum itself
    rxy, gxy = [(0.0, 0.0), (10.0, 0.0)], [(1.0, 0.0), (2.0, 0.0), (9.0, 0.0), (8.0, 0.0)]
    a = run("auction", robots_at(rxy), tasks_at(gxy))
    assert a.travel_lower_bound_m == pytest.approx(4.0) == pytest.approx(a.travel_m)
