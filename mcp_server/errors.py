"""FleetError → MCP tool error (isError) carrying the code, the message and a hint for the assistant."""

from __future__ import annotations

import functools
import inspect
from collections.abc import Awaitable, Callable
from typing import Any, ParamSpec, TypeVar

from mcp.server.mcpserver.exceptions import ToolError

from sim.errors import FleetError

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
}


def tool_error(exc: FleetError) -> ToolError:
    hint = exc.hint or DEFAULT_HINTS.get(exc.code.value, "")
    return ToolError(f"{exc.code.value}: {exc.message}" + (f" | hint: {hint}" if hint else ""))


def fleet_errors(fn: Callable[P, Awaitable[R]]) -> Callable[P, Awaitable[R]]:
    """Decorate an async tool so a FleetError becomes a structured tool error; anything else is a bug and
    is left to the SDK, which reports it as an unexpected error without leaking internals."""
    if not inspect.iscoroutinefunction(fn):
        raise TypeError(f"{fn.__name__} must be async")

    @functools.wraps(fn)
    async def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        try:
            return await fn(*args, **kwargs)
        except FleetError as exc:
            raise tool_error(exc) from exc

    return wrapper


def reraise(exc: Any) -> None:
    if isinstance(exc, FleetError):
        raise tool_error(exc) from exc
    raise exc
