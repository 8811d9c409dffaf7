"""The contestant's controller as a separate process: launch, watch, stop, and read what it said.

The command is a shell-like string split with shlex. It learns where to connect and what to do from
placeholders in the command ({connect}, {world}, {robot}, {goal_x}, {goal_y}, {goal_yaw}, {agent_id}) and
from the same values in the environment (FLEETNAV_CONNECT, FLEETNAV_WORLD, FLEETNAV_ROBOT, FLEETNAV_GOAL as
"x y yaw", FLEETNAV_AGENT_ID, FLEETNAV_LOCKSTEP=1), so `python my_nav.py` works without arguments.
`python` as the first word means this interpreter (the venv with fleetnav installed).
"""

from __future__ import annotations

import contextlib
import os
import shlex
import signal
import subprocess
import sys
from pathlib import Path

from fleet.paths import ROOT
from sim.errors import ErrorCode, FleetError

TAIL_LINES = 20


class AgentProcess:
    def __init__(self, command: str, values: dict[str, str], log_path: Path, cwd: Path | None = None) -> None:
        try:
            argv = [part.format(**values) for part in shlex.split(command)]
        except (ValueError, KeyError, IndexError) as exc:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"cannot parse the agent command {command!r}: {exc}",
                             f"placeholders: {', '.join('{' + k + '}' for k in values)}") from exc
        if not argv:
            raise FleetError(ErrorCode.INVALID_ARGUMENT, "the agent command is empty", 'e.g. "python my_nav.py"')
        if argv[0] in ("python", "python3"):
            argv[0] = sys.executable
        self.argv = argv
        self.log_path = log_path
        log_path.parent.mkdir(parents=True, exist_ok=True)
        env = {**os.environ, **{f"FLEETNAV_{k.upper()}": v for k, v in values.items() if not k.startswith("goal_")},
               "FLEETNAV_GOAL": f"{values['goal_x']} {values['goal_y']} {values['goal_yaw']}",
               "FLEETNAV_LOCKSTEP": "1", "PYTHONUNBUFFERED": "1"}
        # The contestant can `import fleet.agent` even when fleetnav is not installed, only checked out.
        env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), env.get("PYTHONPATH", "")) if p)
        self._log = log_path.open("wb")
        try:
            self.proc = subprocess.Popen(argv, stdout=self._log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                         cwd=cwd, env=env, start_new_session=True)
        except OSError as exc:
            self._log.close()
            raise FleetError(ErrorCode.INVALID_ARGUMENT, f"cannot start the agent {argv[0]!r}: {exc.strerror}",
                             "check the command and that the program exists") from exc

    @property
    def pid(self) -> int:
        return self.proc.pid

    def exit_code(self) -> int | None:
        return self.proc.poll()

    def stop(self, grace_s: float = 2.0) -> int:
        """Terminate (then kill) the process if it still runs; returns its exit code."""
        if self.proc.poll() is None:
            self._signal(signal.SIGTERM)
            try:
                self.proc.wait(grace_s)
            except subprocess.TimeoutExpired:
                self._signal(signal.SIGKILL)
                self.proc.wait(grace_s)
        self._log.close()
        return int(self.proc.returncode)

    def _signal(self, sig: int) -> None:
        """The process's own group (it was started as a session leader), so a shell's children go too."""
        with contextlib.suppress(ProcessLookupError):  # already gone
            os.killpg(self.proc.pid, sig)

    def wait(self, timeout_s: float) -> int | None:
        try:
            return self.proc.wait(timeout_s)
        except subprocess.TimeoutExpired:
            return None

    def tail(self, lines: int = TAIL_LINES) -> str:
        """The last lines the process wrote (stdout and stderr), e.g. its traceback."""
        if not self._log.closed:
            self._log.flush()
        try:
            text = self.log_path.read_text(encoding="utf-8", errors="replace")
        except OSError:
            return ""
        return "\n".join(text.rstrip().splitlines()[-lines:])

    def last_error_line(self) -> str:
        """The most telling line of the output: the exception line of a traceback, else the last line."""
        lines = [ln for ln in self.tail(50).splitlines() if ln.strip()]
        for ln in reversed(lines):
            if not ln.startswith((" ", "\t", "Traceback")) and ("Error" in ln or "Exception" in ln):
                return ln.strip()
        return lines[-1].strip() if lines else "(no output)"
