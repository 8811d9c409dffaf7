"""Drive one run with the contestant's process over the Zenoh API, in lock-step.

The recipe: open the bridge on a free loopback port, the world running in real time → start the process →
wait until it joins lock-step for the robot (meanwhile the robot stands still and its sensors stream, so an
agent may wait for its first scan) → start the episode there (T counts from the join) and run as fast as
the agent answers → watch for the end (goal, collision, time limit from the episode; crash, hang or
disconnect from the process and the bridge; the wall-clock budget) → halt the world → stop the process.
Every way out ends the episode with a reason, so a broken agent is a graded failure, never a hang.
"""

from __future__ import annotations

import socket
import time
from pathlib import Path
from typing import TYPE_CHECKING

from fleet.grading.agent_process import AgentProcess
from fleet.grading.challenge import AgentSection
from fleet.grading.episode import Episode
from fleet.grading.types import Outcome
from sim.clock import ClockMode

if TYPE_CHECKING:
    from fleet.service import FleetService
    from fleet.zenoh_bridge import ZenohBridge

POLL_S = 0.02
CRASH_GRACE_S = 3.0  # wall s a crashing agent gets to finish printing its traceback


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def drive_agent(svc: FleetService, ep: Episode, command: str, log_path: Path, limits: AgentSection,
                cwd: Path | None = None) -> str:
    """Run the episode with the agent in control; returns the tail of the agent's output."""
    from fleet.zenoh_bridge import ZenohBridge
    from fleet.zenoh_config import LockstepConfig, loopback

    port = free_port()
    cfg = loopback(port, listen=True, lockstep=LockstepConfig(enabled=True, timeout_s=limits.tick_timeout_s))
    svc.start(ClockMode.REALTIME)
    with ZenohBridge(svc, cfg) as bridge:
        g = ep.goal
        values = {"connect": f"tcp/127.0.0.1:{port}", "world": bridge.keys.world, "robot": ep.robot,
                  "goal_x": f"{g.x:g}", "goal_y": f"{g.y:g}", "goal_yaw": f"{g.yaw:g}", "agent_id": "contestant"}
        proc = AgentProcess(command, values, log_path, cwd=cwd)
        try:
            if _joined(bridge, proc, ep, limits):
                _begin(svc, bridge, ep, limits)
                _watch(proc, ep, limits)
            _halt(svc, bridge, limits)
        finally:
            if ep.outcome is Outcome.AGENT_CRASHED:
                proc.wait(CRASH_GRACE_S)  # let it print its traceback and exit on its own
            code = proc.stop()
        if ep.outcome is Outcome.AGENT_CRASHED:
            ep.reason += f"; exit code {code}: {proc.last_error_line()}"
        return proc.tail()


def _joined(bridge: ZenohBridge, proc: AgentProcess, ep: Episode, limits: AgentSection) -> bool:
    """Wait (wall clock) until an agent has joined lock-step for the robot; False ends the episode."""
    deadline = time.monotonic() + limits.startup_timeout_s
    while time.monotonic() < deadline:
        if any(ep.robot in robots for robots in list(bridge.gate.agents.values())):
            return True
        code = proc.exit_code()
        if code is not None:
            ep.finish(Outcome.AGENT_CRASHED, f"the agent exited before joining lock-step for '{ep.robot}'")
            return False
        time.sleep(POLL_S)
    ep.finish(Outcome.AGENT_DID_NOT_CONNECT,
              f"the agent did not join lock-step for robot '{ep.robot}' within {limits.startup_timeout_s:g} s "
              "(connect to FLEETNAV_CONNECT and call Agent.lockstep([robot], step))")
    return False


def _begin(svc: FleetService, bridge: ZenohBridge, ep: Episode, limits: AgentSection) -> None:
    """Start the episode exactly at a control-tick boundary, before that tick's control (T counts from there),
    and from then on run as fast as the agent answers. Runs on the sim thread: inside the gate if it already
    waits for the agent, else between physics steps, in which case the start waits for the next tick."""
    gate = bridge.gate
    k = max(1, round(svc.config.physics_hz / svc.config.control_hz))  # physics steps per control tick

    def start() -> None:
        ep.controlled = lambda: any(ep.robot in robots for robots in gate.agents.values())
        ep.start()
        svc.clock.set_mode(ClockMode.FAST, svc.world)

    def at_next_tick(now: float) -> None:
        svc.control_gate = gate
        start()
        gate(now)

    def begin() -> None:
        if svc.world.step_count % k == 0:  # at a boundary: this tick's control has not run yet
            start()
        else:
            svc.control_gate = at_next_tick

    gate.run(begin).result(timeout=limits.tick_timeout_s + 10.0)


def _watch(proc: AgentProcess, ep: Episode, limits: AgentSection) -> None:
    deadline = time.monotonic() + limits.wall_limit_s
    while not ep.done.wait(POLL_S):
        if proc.exit_code() is not None:
            ep.finish(Outcome.AGENT_CRASHED, "the agent exited before the run ended")
        elif time.monotonic() > deadline:
            ep.finish(Outcome.WALL_TIMEOUT, f"the run took more than {limits.wall_limit_s:g} s of wall time "
                                            f"(sim time {ep.elapsed:.1f} s)")


def _halt(svc: FleetService, bridge: ZenohBridge, limits: AgentSection) -> None:
    """Pause the world and release it from lock-step, from inside the gate if it is waiting there."""
    gate = bridge.gate

    def halt() -> None:
        for agent in list(gate.agents):
            gate.unregister(agent)
        svc.clock.set_mode(ClockMode.PAUSED, svc.world)

    gate.run(halt).result(timeout=limits.tick_timeout_s + 10.0)
