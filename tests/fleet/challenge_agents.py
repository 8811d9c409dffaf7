"""Misbehaving contestants for the challenge tests, each a real process over the Zenoh API in lock-step.

    python tests/fleet/challenge_agents.py wall|crash|hang|idle

They read where to connect and which robot from the environment the challenge runner sets (FLEETNAV_CONNECT,
FLEETNAV_ROBOT), as a student's `python my_nav.py` would.
- wall:  drive straight ahead at 0.5 m/s, whatever is in the way;
- crash: answer 5 ticks, then raise an exception;
- hang:  answer 5 ticks, then stop answering (alive, silent);
- idle:  connect, never join lock-step.
"""

from __future__ import annotations

import os
import sys
import time

from fleet.agent import Agent

SPEED = 0.5


def main(mode: str) -> int:
    robot = os.environ["FLEETNAV_ROBOT"]
    with Agent("misbehaving", connect=os.environ["FLEETNAV_CONNECT"]) as agent:
        if mode == "idle":
            time.sleep(3600)

        def step(tick: int, stamp: float) -> dict[str, tuple[float, float]]:
            step.count += 1  # type: ignore[attr-defined]
            if mode == "crash" and step.count > 5:  # type: ignore[attr-defined]
                raise RuntimeError("controller blew up on purpose")
            if mode == "hang" and step.count > 5:  # type: ignore[attr-defined]
                time.sleep(3600)
            return {robot: (SPEED, 0.0)}

        step.count = 0  # type: ignore[attr-defined]
        agent.lockstep([robot], step, tick_timeout=3600)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
