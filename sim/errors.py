"""The one exception family every front door maps once (see docs/decisions.md).

It lives in `sim` because `sim` is the bottom of the dependency graph: every other package may import it,
and `fleet` re-exports it as its public error type.
"""

from __future__ import annotations

from enum import StrEnum


class ErrorCode(StrEnum):
    UNKNOWN_ROBOT = "UNKNOWN_ROBOT"
    UNKNOWN_MODEL = "UNKNOWN_MODEL"
    INVALID_ARGUMENT = "INVALID_ARGUMENT"
    INVALID_CONFIG = "INVALID_CONFIG"
    PLANNING_FAILED = "PLANNING_FAILED"
    COLLISION = "COLLISION"
    OUT_OF_BOUNDS = "OUT_OF_BOUNDS"
    PATH_NOT_ALLOWED = "PATH_NOT_ALLOWED"
    LIMIT_EXCEEDED = "LIMIT_EXCEEDED"
    ESTOPPED = "ESTOPPED"
    LEASE_HELD = "LEASE_HELD"
    PHYSICS_UNSTABLE = "PHYSICS_UNSTABLE"
    NOT_FOUND = "NOT_FOUND"
    UNSUPPORTED = "UNSUPPORTED"
    BUSY = "BUSY"
    TIMEOUT = "TIMEOUT"
    SIM_DEAD = "SIM_DEAD"
    INTERNAL = "INTERNAL"


class FleetError(Exception):
    """An error a user can act on: a stable code, what happened, and what to do next."""

    def __init__(self, code: ErrorCode | str, message: str, hint: str = "") -> None:
        self.code = ErrorCode(code)
        self.message = message
        self.hint = hint
        super().__init__(f"{self.code.value}: {message}" + (f" ({hint})" if hint else ""))

    def to_dict(self) -> dict[str, str]:
        return {"code": self.code.value, "message": self.message, "hint": self.hint}


def unknown_name(kind: str, name: str, known: list[str] | tuple[str, ...], code: ErrorCode) -> FleetError:
    """The error for a name that is not registered, listing the valid ones."""
    listing = ", ".join(sorted(known)) if known else "(none)"
    return FleetError(code, f"unknown {kind} '{name}'", f"known {kind}s: {listing}")
