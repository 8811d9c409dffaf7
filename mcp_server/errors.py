"""FleetError → MCP tool error (isError) carrying the code, the message and a hint for the assistant."""

from __future__ import annotations

import functools
import inspect
from collections.abc import Awaitable, Callable
from typing import Any, ParamSpec, TypeVar

import anyio
from mcp.server.mcpserver.exceptions import ToolError
from pydantic import ValidationError

from fleet.supervision import internal
from fleet.validation import summarize
from sim.errors import ErrorCode, FleetError

P = ParamSpec("P")
R = TypeVar("R")

# What an assistant should do next, per code, when the error itself has no hint.
DEFAULT_HINTS = {
    "UNKNOWN_ROBOT": "call list_robots to see the robots",
    "UNKNOWN_MODEL": "call list_models to see the models",
    "PLANNING_FAILED": "pick a goal in free space (see get_occupancy_map) or another planner",
    "ESTOPPED": "call rearm for that robot (or the fleet) first",
    "LEASE_HELD": "another client controls this robot; wait or ask it to release",
    "PATH_NOT_ALLOWED": "use a path inside the workspace directory",
    "INVALID_ARGUMENT": "check the argument against the tool's input schema",
    "SIM_DEAD": "call sim_health, then restart_simulation",
}


def tool_error(exc: FleetError, sim_time: float | None = None) -> ToolError:
    hint = exc.hint or DEFAULT_HINTS.get(exc.code.value, "")
    return ToolError(f"{exc.code.value}: {exc.message}" + (f" | hint: {hint}" if hint else "")
                     + (f" | sim_time: {sim_time:.3f}" if sim_time is not None else ""))


def _now(kwargs: dict[str, Any]) -> float | None:
    """Sim time read after the failed command (errors are stamped like answers)."""
    ctx = kwargs.get("ctx")
    try:
        return float(ctx.request_context.lifespan_context.service.sim_time)  # type: ignore[union-attr]
    except Exception:  # no service reachable (e.g. built without lifespan): no stamp
        return None


def fleet_errors(fn: Callable[P, Awaitable[R]]) -> Callable[P, Awaitable[R]]:
    """Decorate an async tool so every failure is a structured tool error stamped with the sim time: a
    FleetError as is, a pydantic ValidationError (a config dict, a task spec) as one INVALID_ARGUMENT line (no
    raw dump), anything else as INTERNAL naming the exception."""
    if not inspect.iscoroutinefunction(fn):
        raise TypeError(f"{fn.__name__} must be async")

    @functools.wraps(fn)
    async def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        try:
            return await fn(*args, **kwargs)
        except FleetError as exc:
            raise tool_error(exc, _now(kwargs)) from exc
        except ValidationError as exc:
            err = FleetError(ErrorCode.INVALID_ARGUMENT, summarize(exc))
            raise tool_error(err, _now(kwargs)) from exc
        except (ToolError, anyio.get_cancelled_exc_class()):
            raise
        except Exception as exc:
            raise tool_error(internal(exc), _now(kwargs)) from exc

    return wrapper


def reraise(exc: Any) -> None:
    if isinstance(exc, FleetError):
        raise tool_error(exc) from exc
    raise exc
