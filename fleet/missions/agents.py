"""External agents of a mission: processes that drive robots over the Zenoh API while the mission runs.

The recipe: open a Zenoh bridge on a free loopback port with the world paused → launch each agent's command
(placeholders and FLEETNAV_* variables tell it where to connect) → wait until the lock-step agents have
joined → run the world as fast as they answer → at the end halt the world, release the lock-step, stop the
processes and keep each one's exit code and output tail. With lock-step (the default) the world waits for
the agents every control tick, so a run does not depend on wall-clock speed.
"""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fleet.missions.schema import AgentEntry, AgentsSection
from fleet.paths import ROOT
from sim.clock import ClockMode
from sim.errors import ErrorCode, FleetError

if TYPE_CHECKING:
    from fleet.service import FleetService
    from fleet.zenoh_bridge import ZenohBridge

POLL_S = 0.02


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class AgentProcess:
    def __init__(self, entry: AgentEntry, values: dict[str, str], log_path: Path) -> None:
        self.entry, self.log_path = entry, log_path
        try:
            argv = [part.format(**values) for part in entry.command]
        except (KeyError, IndexError, ValueError) as exc:
            raise FleetError(ErrorCode.INVALID_CONFIG, f"agent {entry.name}: bad placeholder in {entry.command}: {exc}",
                             f"placeholders: {', '.join('{' + k + '}' for k in values)}") from exc
        if argv[0] in ("python", "python3"):
            argv[0] = sys.executable  # the interpreter fleetnav runs in
        env = {**os.environ, **{f"FLEETNAV_{k.upper()}": v for k, v in values.items()}, **entry.env,
               "PYTHONUNBUFFERED": "1",
               "PYTHONPATH": os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH", "")) if p)}
        log_path.parent.mkdir(parents=True, exist_ok=True)
        self._log = log_path.open("wb")
        try:
            self.proc = subprocess.Popen(argv, stdout=self._log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                         env=env, start_new_session=True)
        except OSError as exc:
            self._log.close()
            raise FleetError(ErrorCode.INVALID_CONFIG, f"agent {entry.name}: cannot start {argv[0]!r}: "
                             f"{exc.strerror}") from exc

    def exit_code(self) -> int | None:
        return self.proc.poll()

    def stop(self, grace_s: float = 2.0) -> int:
        if self.proc.poll() is None:
            with contextlib.suppress(ProcessLookupError):  # it may have just exited
                os.killpg(self.proc.pid, signal.SIGTERM)
            try:
                self.proc.wait(grace_s)
            except subprocess.TimeoutExpired:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait(grace_s)
        self._log.close()
        return int(self.proc.returncode)

    def tail(self, lines: int = 10) -> str:
        text = self.log_path.read_text(encoding="utf-8", errors="replace") if self.log_path.is_file() else ""
        return "\n".join(text.rstrip().splitlines()[-lines:])


class AgentSession:
    """The bridge and the agents' processes for one run (service mode: the world runs on its sim thread)."""

    def __init__(self, svc: FleetService, section: AgentsSection, out_dir: Path, mission_dir: Path) -> None:
        self.svc, self.section, self.out, self.mission_dir = svc, section, out_dir, mission_dir
        self.procs: list[AgentProcess] = []
        self.bridge: ZenohBridge | None = None

    def start(self) -> None:
        from fleet.zenoh_bridge import ZenohBridge
        from fleet.zenoh_config import LockstepConfig, loopback

        s = self.section
        port = free_port()
        self.svc.start(ClockMode.PAUSED)
        cfg = loopback(port, listen=True, lockstep=LockstepConfig(enabled=s.lockstep, timeout_s=s.tick_timeout_s))
        self.bridge = ZenohBridge(self.svc, cfg).start()
        for e in s.processes:
            values = {"connect": f"tcp/127.0.0.1:{port}", "world": self.bridge.keys.world, "agent_id": e.name,
                      "robots": ",".join(e.robots), "robot": e.robots[0] if e.robots else "",
                      "lockstep": "1" if s.lockstep else "0", "mission_dir": str(self.mission_dir)}
            self.procs.append(AgentProcess(e, values, self.out / f"agent_{e.name}.log"))

    def wait_joined(self) -> None:
        """Until every lock-step agent with robots has joined (wall clock); a crash or a timeout raises."""
        assert self.bridge is not None
        want = {e.name for e in self.section.processes if e.robots} if self.section.lockstep else set()
        deadline = time.monotonic() + self.section.startup_timeout_s
        while not want <= set(self.bridge.gate.agents):
            for p in self.procs:
                code = p.exit_code()
                if code is not None and p.entry.name in want:
                    raise FleetError(ErrorCode.INTERNAL, f"agent {p.entry.name} exited ({code}) before joining "
                                     f"lock-step: {p.tail(3)}")
            if time.monotonic() > deadline:
                raise FleetError(ErrorCode.TIMEOUT, f"agents {', '.join(sorted(want - set(self.bridge.gate.agents)))} "
                                 f"did not join lock-step within {self.section.startup_timeout_s:g} s",
                                 "they connect to FLEETNAV_CONNECT and call Agent.lockstep(robots, step)")
            time.sleep(POLL_S)

    def finished(self) -> bool:
        """With lock-step: every agent has left it (a sim-time event, so the end is deterministic); without:
        every process has exited."""
        if self.section.lockstep and self.bridge is not None:
            return not self.bridge.gate.agents
        return all(p.exit_code() is not None for p in self.procs)

    def crashed(self) -> list[str]:
        return [f"agent {p.entry.name} exited with {p.exit_code()}: {p.tail(3)}" for p in self.procs
                if p.entry.required and p.exit_code() not in (None, 0)]

    def stop(self) -> dict[str, dict[str, Any]]:
        """Halt the world (releasing lock-step from inside the gate), stop the processes, close the bridge."""
        out: dict[str, dict[str, Any]] = {}
        if self.bridge is not None:
            gate = self.bridge.gate

            def halt() -> None:
                for agent in list(gate.agents):
                    gate.unregister(agent)
                self.svc.clock.set_mode(ClockMode.PAUSED, self.svc.world)

            gate.run(halt).result(timeout=self.section.tick_timeout_s + 10.0)
        deadline = time.monotonic() + self.section.exit_grace_s  # let agents that are done exit by themselves
        while not all(p.exit_code() is not None for p in self.procs) and time.monotonic() < deadline:
            time.sleep(POLL_S)
        for p in self.procs:
            running = p.exit_code() is None
            code = p.stop()
            out[p.entry.name] = {"exit_code": None if running else code, "stopped": running, "output": p.tail()}
        if self.bridge is not None:
            self.bridge.close()
        self.svc.stop()
        return out
