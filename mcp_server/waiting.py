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
PROGRESS_EVERY_S = 0.5  # wall seconds between progress notifications (≤ 2/s, plus the final one)


async def advance(ctx: Context, seconds: float, *, done: Callable[[], Awaitable[bool]] | None = None,
                  message: Callable[[], str] | None = None, max_wall_s: float = 60.0) -> bool:
    """Let up to `seconds` of sim time pass (or until `done()`); True when `done()` became true."""
    svc = app_of(ctx).service
    t0 = svc.snapshot.time
    end = t0 + seconds
    wall_end = anyio.current_time() + max_wall_s
    now = t0
    last_report, reported = -PROGRESS_EVERY_S, t0

    async def report() -> None:
        nonlocal last_report, reported
        last_report, reported = anyio.current_time(), now
        await ctx.report_progress(min(now - t0, seconds), seconds, message() if message else None)

    while True:
        finished = done is not None and await done()
        if finished or now >= end - 1e-9 or anyio.current_time() > wall_end:
            if now > reported:  # the final progress, even when the last one was sent < 0.5 s ago
                await report()
            return finished
        if svc.clock.mode is ClockMode.PAUSED or not svc.threaded:  # nobody else steps it: step it here
            steps = max(1, round(min(CHUNK_S, end - now) * svc.world.physics_hz))
            now = await run(ctx, svc.step, steps)
        else:
            await anyio.sleep(0.05)
            now = svc.snapshot.time
        if anyio.current_time() - last_report >= PROGRESS_EVERY_S:
            await report()
