"""Waiting for sim time to pass inside a tool, with MCP progress notifications.

When the clock runs (service mode, real time or fast) the tool sleeps and watches the snapshot; when it is
paused, or there is no sim thread (batch mode), the tool steps the simulation itself, in chunks, so a
waiting tool never hangs on a stopped clock. Wall time is capped: a wait that runs out says so and the
action carries on (its id is in the answer)."""

from __future__ import annotations

from collections.abc import Awaitable, Callable

import anyio
from mcp.server.mcpserver import Context

from mcp_server.app import app_of, run
from sim import ClockMode

CHUNK_S = 0.5  # sim seconds stepped per iteration on a paused clock
PROGRESS_EVERY_S = 0.5  # wall seconds between progress notifications (≤ 2/s, however fast the loop turns)


async def advance(ctx: Context, seconds: float, *, done: Callable[[], Awaitable[bool]] | None = None,
                  message: Callable[[], str] | None = None, max_wall_s: float = 60.0) -> bool:
    """Let up to `seconds` of sim time pass (or until `done()`); True when `done()` became true."""
    svc = app_of(ctx).service
    t0 = svc.snapshot.time
    end = t0 + seconds
    wall_end = anyio.current_time() + max_wall_s
    now = t0
    last_report = -PROGRESS_EVERY_S
    while True:
        if done is not None and await done():
            return True
        if now >= end - 1e-9 or anyio.current_time() > wall_end:
            return False
        if svc.clock.mode is ClockMode.PAUSED or not svc.threaded:  # nobody else steps it: step it here
            steps = max(1, round(min(CHUNK_S, end - now) * svc.world.physics_hz))
            now = await run(ctx, svc.step, steps)
        else:
            await anyio.sleep(0.05)
            now = svc.snapshot.time
        if anyio.current_time() - last_report >= PROGRESS_EVERY_S:
            last_report = anyio.current_time()
            await ctx.report_progress(min(now - t0, seconds), seconds, message() if message else None)
