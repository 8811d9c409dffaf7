"""`fleetnav teleop` driven through a pseudo-terminal: keys move the robot in the world, within the limits."""

from __future__ import annotations

import os
import re
import select
import subprocess
import time

import pytest

from fleetnav.cmd_teleop import Teleop, keys_of
from tests.e2e.served_world import cli, env, served_world

pytest.importorskip("zenoh")

MAX_SPEED = 0.4


def test_ramp_stays_within_the_acceleration_limits():
    t = Teleop(max_v=0.4, max_w=1.0, accel=0.5, alpha=2.0, step_v=0.1, step_w=0.2)
    for k in keys_of("wwwwwww\x1b[D"):  # 7 × 0.1 clamps at 0.4; ← is a left turn step
        t.key(k)
    assert (t.target_v, t.target_w) == (0.4, 0.2)
    vs = [t.update(0.1)[0] for _ in range(12)]
    assert vs[:8] == pytest.approx([0.05 * k for k in range(1, 9)])  # 0.5 m/s² × 0.1 s per beat
    assert max(vs) == pytest.approx(0.4)
    assert t.key(" ") and (t.target_v, t.target_w) == (0.0, 0.0)
    assert not t.key("q")


class Pty:
    def __init__(self, argv: list[str]) -> None:
        self.master, slave = os.openpty()
        self.proc = subprocess.Popen(argv, stdin=slave, stdout=slave, stderr=slave, env=env(),
                                     start_new_session=True)
        os.close(slave)
        self.out = ""

    def read_until(self, pattern: str, timeout: float, since: int = 0) -> str:
        """Wait for `pattern` in the output written after offset `since` (output left after exit included)."""
        deadline = time.monotonic() + timeout
        while not re.search(pattern, self.out[since:]):
            left = deadline - time.monotonic()
            ready = left > 0 and select.select([self.master], [], [], min(left, 0.2))[0]
            chunk = b""
            if ready:
                try:
                    chunk = os.read(self.master, 4096)
                except OSError:  # EIO: the child closed the terminal
                    chunk = b""
                self.out += chunk.decode(errors="replace")
            if left <= 0 or (not chunk and self.proc.poll() is not None):
                raise AssertionError(f"no {pattern!r} in teleop output:\n{self.out[-1500:]}")
        return self.out

    def send(self, keys: str) -> None:
        os.write(self.master, keys.encode())

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(5)
        os.close(self.master)


def test_keys_in_a_terminal_drive_the_robot_in_the_world():
    with served_world() as world:
        svc = world.service
        term = Pty(cli("teleop", "r1", "--connect", world.endpoint, "--max-speed", str(MAX_SPEED), "--accel", "1.0"))
        try:
            term.read_until(r"\| x=[+-]", timeout=30)  # connected, pose arriving
            x0 = svc.snapshot.pose[0, 0]
            term.send("w" * 7)  # seven steps of 0.1 m/s: the target clamps at the maximum speed
            top, t_end = 0.0, time.monotonic() + 2.5
            while time.monotonic() < t_end:
                top = max(top, float(svc.snapshot.twist[0, 0]))
                time.sleep(0.02)
            term.read_until(r"cmd v=\+0\.40", timeout=5)
            mark = len(term.out)
            term.send(" ")
            term.read_until(r"target v=\+0\.00 w=\+0\.00 \| cmd v=\+0\.00", timeout=5, since=mark)
            time.sleep(0.3)
            assert abs(float(svc.snapshot.twist[0, 0])) < 1e-6  # stopped
            term.send("q")
            term.read_until("stopped", timeout=10)
            assert term.proc.wait(10) == 0
        finally:
            term.close()
        moved = float(svc.snapshot.pose[0, 0]) - x0
        assert 0.5 < moved < MAX_SPEED * 4.0  # ~2.5 s at up to 0.4 m/s, straight ahead
        assert abs(float(svc.snapshot.pose[0, 1])) < 0.05
        assert MAX_SPEED - 0.02 < top <= MAX_SPEED + 1e-9  # reached, never exceeded
        # the command ramped (1 m/s² at 10 Hz: 0.1 m/s per beat), it did not jump to the target
        cmds = [float(v) for v in re.findall(r"cmd v=([+-]\d\.\d\d)", term.out)]
        assert any(0.05 < c < 0.35 for c in cmds)
