"""Supervision of the sim thread: what it is doing, how commands fail, and why it died.

The sim thread runs every command between physics steps. A command that raises fails with a FleetError (a
non-FleetError becomes INTERNAL naming the exception) and the world keeps stepping. A command that steps the
world checks its wall budget at every step and stops with TIMEOUT when it overruns, so no caller waits
forever behind it. If the thread dies anyway, every pending and later call fails at once with SIM_DEAD and
`health()` says why; `FleetService.restart()` rebuilds the world.
"""

from __future__ import annotations

import time
import traceback
from dataclasses import dataclass, field
from typing import Any

from sim.errors import ErrorCode, FleetError

CMD_BUDGET_S = 20.0  # wall seconds a command may hold the sim thread in service mode
MAX_TICK_FAILURES = 20  # consecutive failing ticks of the loop itself before the thread gives up


@dataclass
class Health:
    alive: bool = True
    dead_reason: str | None = None
    died_at_wall: float | None = None
    command: str | None = None  # what the sim thread runs now
    command_started: float | None = None
    command_errors: int = 0  # commands that raised a non-FleetError (reported as INTERNAL)
    overruns: int = 0  # commands stopped at their budget
    tick_errors: int = 0
    last_error: str | None = None
    restarts: int = 0
    recent: list[str] = field(default_factory=list)

    def note(self, what: str) -> None:
        self.last_error = what
        self.recent = [*self.recent[-9:], what]

    def to_dict(self) -> dict[str, Any]:
        busy = None if self.command_started is None else round(time.perf_counter() - self.command_started, 3)
        return {"alive": self.alive, "dead_reason": self.dead_reason, "command": self.command, "busy_for_s": busy,
                "command_errors": self.command_errors, "overruns": self.overruns, "tick_errors": self.tick_errors,
                "last_error": self.last_error, "restarts": self.restarts, "recent_errors": list(self.recent)}


def describe(fn: Any) -> str:
    """A short label for a queued callable: its qualified name without the `<locals>` noise."""
    name = getattr(fn, "__qualname__", None) or type(fn).__name__
    return str(name).replace(".<locals>", "")


def internal(exc: BaseException) -> FleetError:
    """A bug in a command (not the caller's fault): INTERNAL with the exception type, never a traceback."""
    tb = traceback.extract_tb(exc.__traceback__)
    where = f" at {tb[-1].filename.rsplit('/', 1)[-1]}:{tb[-1].lineno}" if tb else ""
    return FleetError(ErrorCode.INTERNAL, f"the command failed: {type(exc).__name__}: {str(exc)[:200]}{where}",
                      "the world keeps running; check the arguments, and report this as a fleetnav bug")


def dead(reason: str | None) -> FleetError:
    return FleetError(ErrorCode.SIM_DEAD, f"the simulation thread has stopped: {reason or 'unknown reason'}",
                      "call sim_health for details and restart_simulation to rebuild the world")


def overrun(budget: float, t: float) -> FleetError:
    return FleetError(ErrorCode.TIMEOUT, f"the command overran its budget of {budget:g} s wall and was stopped at "
                      f"sim time {t:.3f} s", "ask for fewer steps (or a shorter wait) per call")
