"""`fleetnav teleop ROBOT`: drive a robot from the keyboard over the Zenoh API (the course's teleop node).

Keys set a target velocity, as turtlebot3_teleop_key does: w/x (or ↑/↓) step the linear target, a/d (or ←/→)
the angular one, s or space stop, q quits. The command sent ramps toward the target within the acceleration
limits and never exceeds the maximum speeds given here; the world's safety envelope applies its own limits on
top. Commands go out at `--rate` Hz, which also keeps the world's deadman alive; on quit (or Ctrl-C) the robot
is stopped. The status line shows the target, the command sent and the robot's pose with its sim time.
"""

from __future__ import annotations

import contextlib
import math
import os
import select
import sys
import termios
import time
import tty
from collections.abc import Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING

import typer

if TYPE_CHECKING:
    from fleet.agent import Agent, RobotLink

ARROWS = {"\x1b[A": "w", "\x1b[B": "x", "\x1b[C": "d", "\x1b[D": "a"}
HELP = "w/x: faster/slower  a/d: left/right  s/space: stop  q: quit"


@dataclass
class Teleop:
    """Keys → target velocity; `update(dt)` → the command, ramped toward the target within the limits."""

    max_v: float
    max_w: float
    accel: float
    alpha: float
    step_v: float
    step_w: float
    target_v: float = 0.0
    target_w: float = 0.0
    v: float = 0.0
    w: float = 0.0

    def key(self, k: str) -> bool:
        """Apply one key; False means quit."""
        if k == "q":
            return False
        if k in "wx":
            self.target_v += self.step_v if k == "w" else -self.step_v
        elif k in "ad":
            self.target_w += self.step_w if k == "a" else -self.step_w
        elif k in "s ":
            self.target_v = self.target_w = 0.0
        self.target_v = _clip(round(self.target_v, 9), self.max_v)
        self.target_w = _clip(round(self.target_w, 9), self.max_w)
        return True

    def update(self, dt: float) -> tuple[float, float]:
        self.v += _clip(self.target_v - self.v, self.accel * dt)
        self.w += _clip(self.target_w - self.w, self.alpha * dt)
        return self.v, self.w


def _clip(x: float, limit: float) -> float:
    return max(-limit, min(limit, x))


def keys_of(data: str) -> list[str]:
    """Split terminal input into keys, arrow escape sequences mapped to w/x/a/d."""
    out, i = [], 0
    while i < len(data):
        seq = data[i:i + 3]
        if seq in ARROWS:
            out.append(ARROWS[seq])
            i += 3
        else:
            out.append(data[i].lower())
            i += 1
    return out


@contextlib.contextmanager
def _cbreak(fd: int) -> Iterator[None]:
    """Keys arrive one at a time, unechoed; the terminal is restored however we leave."""
    if not os.isatty(fd):
        yield
        return
    saved = termios.tcgetattr(fd)
    try:
        tty.setcbreak(fd)
        yield
    finally:
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)


def teleop(robot: str = typer.Argument(..., help="the robot to drive"),
           connect: str = typer.Option("tcp/127.0.0.1:7447", help="the world's Zenoh endpoint"),
           world: str | None = typer.Option(None, help="world key, if several worlds share the network"),
           max_speed: float = typer.Option(0.5, min=0.01, max=10.0, help="m/s"),
           max_turn: float = typer.Option(1.0, min=0.01, max=20.0, help="rad/s"),
           accel: float = typer.Option(0.5, min=0.01, max=20.0, help="linear acceleration limit, m/s²"),
           alpha: float = typer.Option(2.0, min=0.01, max=50.0, help="angular acceleration limit, rad/s²"),
           step: float = typer.Option(0.1, min=0.001, help="linear target change per key, m/s"),
           turn_step: float = typer.Option(0.2, min=0.001, help="angular target change per key, rad/s"),
           rate: float = typer.Option(10.0, min=1.0, max=50.0, help="commands per second (wall)"),
           agent_id: str = typer.Option("teleop", help="the client id (it takes the robot's lease)")) -> None:
    """Keyboard control of ROBOT over Zenoh, with speed and acceleration limits."""
    from fleet.agent import Agent
    from sim.errors import FleetError

    state = Teleop(max_speed, max_turn, accel, alpha, step, turn_step)
    fd = sys.stdin.fileno()
    try:
        with Agent(agent_id, connect=connect, world=world) as agent, _cbreak(fd):
            link = agent.robot(robot, streams=("pose",))
            typer.echo(f"teleop {robot} on world '{agent.keys.world}': {HELP}")
            try:
                _loop(state, link, agent, fd, 1.0 / rate)
            finally:
                link.stop()
                typer.echo("\nstopped")
    except FleetError as exc:
        typer.echo(f"error: {exc.message}" + (f" ({exc.hint})" if exc.hint else ""), err=True)
        raise typer.Exit(2) from exc
    except KeyboardInterrupt:
        pass


def _loop(state: Teleop, link: RobotLink, agent: Agent, fd: int, period: float) -> None:
    last = time.monotonic()
    while True:
        ready, _, _ = select.select([fd], [], [], period)
        if ready:
            data = os.read(fd, 64).decode(errors="ignore")
            if not data or not all(state.key(k) for k in keys_of(data)):  # EOF or q
                return
        now = time.monotonic()
        if now - last < period and ready:
            continue  # a key: apply it, send on the regular beat
        v, w = state.update(now - last)
        last = now
        link.drive(v, w)
        p = link.pose
        pose = f"x={p.x:+.2f} y={p.y:+.2f} yaw={math.degrees(p.yaw):+.0f}° t={p.stamp:.1f}s" if p else "pose: waiting"
        err = f"  [{agent.errors[-1]['code']}: {agent.errors[-1]['message']}]" if agent.errors else ""
        sys.stdout.write(f"\r\x1b[Ktarget v={state.target_v:+.2f} w={state.target_w:+.2f} | "
                         f"cmd v={v:+.2f} w={w:+.2f} | {pose}{err}")
        sys.stdout.flush()
