"""Clock.steps_due(early=True): a waiting command's physics step may run before its wall time, but the sim
never leads wall time by more than one step, and the rate stays the clock's speed."""

from __future__ import annotations

import pytest

import sim.clock as clock_mod
from sim import World
from sim.clock import Clock, ClockMode


@pytest.fixture
def wall(monkeypatch: pytest.MonkeyPatch) -> list[float]:
    now = [100.0]
    monkeypatch.setattr(clock_mod.time, "perf_counter", lambda: now[0])
    return now


def test_early_step_leads_by_at_most_one_step(wall: list[float]) -> None:
    with World(physics_hz=100.0) as w:
        c = Clock()
        c.set_mode(ClockMode.REALTIME, w)
        wall[0] += 0.004  # 4 ms into the first 10 ms step
        assert c.steps_due(w) == 0
        assert c.steps_due(w, early=True) == 1  # a command waits: step now
        w.step()
        assert c.steps_due(w, early=True) == 0  # already one step ahead: no further
        assert c.seconds_until_next_step(w) == pytest.approx(0.016)  # the next step waits the lead out
        wall[0] += 0.011  # 15 ms: the sim (10 ms) is behind again, the second step not yet due
        assert c.steps_due(w) == 0 and c.steps_due(w, early=True) == 1
        w.step()
        wall[0] += 0.0355  # 50.5 ms: late: owed steps are counted as before, early or not
        assert c.steps_due(w) == c.steps_due(w, early=True) == 3


def test_early_has_no_effect_when_paused_or_fast(wall: list[float]) -> None:
    with World(physics_hz=50.0) as w:
        c = Clock()
        c.set_mode(ClockMode.PAUSED, w)
        assert c.steps_due(w, early=True) == 0
        c.set_mode(ClockMode.FAST, w)
        assert c.steps_due(w, max_steps=7, early=True) == 7
