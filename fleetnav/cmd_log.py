"""`fleetnav log ROBOT --out DIR`: record a robot's sensor streams over Zenoh to CSV, then print statistics.

One CSV per stream (odom, imu, scan, pose), one row per message, the sim-time `stamp` first. Scans keep every
range (r0 … r{n-1}, `inf` = no return) after three summary columns (`returns`: valid beams, `range_min`,
`range_mean`); IMU vectors are gx gy gz (rad/s), ax ay az (m/s²), qx qy qz qw. The window is `--duration`
sim seconds from the first message (half-open: a 10 Hz stream gives 10 rows a second), or until Ctrl-C. At the
end a table gives, per channel and column, min / max / mean and the channel's rate (from the stamps); it is
also written to stats.csv. The camera is not a stream (it renders on request).
"""

from __future__ import annotations

import csv
import json
import math
import queue
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import typer

STREAMS = ("odom", "imu", "scan", "pose")
# Short column names for the IMU's vectors, as ROS tools print them: gyro g*, accelerometer a*, quaternion q*.
VECTOR_NAMES = {"orientation": ("qx", "qy", "qz", "qw"), "angular_velocity": ("gx", "gy", "gz"),
                "linear_acceleration": ("ax", "ay", "az")}


def row_of(stream: str, payload: bytes) -> dict[str, Any]:
    """A message as a flat CSV row, stamp first."""
    if stream == "scan":
        import numpy as np

        from fleet.zenoh_api import decode_scan

        s = decode_scan(payload)
        r = s.ranges.astype(float)
        ok = r[np.isfinite(r)]
        head = {"stamp": s.stamp, "returns": int(ok.size), "range_min": float(ok.min()) if ok.size else math.nan,
                "range_mean": float(ok.mean()) if ok.size else math.nan}
        return head | {f"r{i}": float(v) for i, v in enumerate(r)}
    d = json.loads(payload)
    out: dict[str, Any] = {"stamp": d["stamp"]}
    for k, v in d.items():
        if k in ("stamp", "frame_id", "child_frame_id"):
            continue
        if isinstance(v, list):
            names = VECTOR_NAMES.get(k, tuple(f"{k}_{i}" for i in range(len(v))))
            out |= dict(zip(names, v, strict=True))
        else:
            out[k] = v
    return out


class Channel:
    """One stream's CSV file and running statistics."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._file = path.open("w", newline="", encoding="utf-8")
        self._writer: Any = None
        self.rows = 0
        self.first = self.last = math.nan
        self.values: dict[str, list[float]] = {}

    def write(self, row: dict[str, Any]) -> None:
        if self._writer is None:
            self._writer = csv.DictWriter(self._file, fieldnames=list(row))
            self._writer.writeheader()
            self.values = {k: [] for k in row if k != "stamp" and not _is_beam(k)}
        self._writer.writerow(row)
        self.rows += 1
        self.first = row["stamp"] if self.rows == 1 else self.first
        self.last = row["stamp"]
        for k, col in self.values.items():
            col.append(float(row[k]))

    def close(self) -> None:
        self._file.close()

    @property
    def rate(self) -> float:
        return (self.rows - 1) / (self.last - self.first) if self.rows > 1 and self.last > self.first else math.nan

    def stats(self) -> list[tuple[str, float, float, float]]:
        """(column, min, max, mean) over finite values."""
        import numpy as np

        out = []
        for k, col in self.values.items():
            a = np.asarray(col, dtype=float)
            a = a[np.isfinite(a)]
            if a.size:
                out.append((k, float(a.min()), float(a.max()), float(a.mean())))
            else:
                out.append((k, math.nan, math.nan, math.nan))
        return out


def _is_beam(key: str) -> bool:
    return key.startswith("r") and key[1:].isdigit()


def log(robot: str = typer.Argument(..., help="the robot whose sensors to record"),
        out: Path = typer.Option(..., "--out", help="directory for the CSV files"),
        connect: str = typer.Option("tcp/127.0.0.1:7447", help="the world's Zenoh endpoint"),
        world: str | None = typer.Option(None, help="world key, if several worlds share the network"),
        duration: float | None = typer.Option(None, min=0.01, help="sim seconds to record (default: until Ctrl-C)"),
        streams: str = typer.Option(",".join(STREAMS), help="comma-separated streams"),
        idle_timeout: float = typer.Option(10.0, min=0.1, help="give up after this many wall s without data"),
        agent_id: str = typer.Option("logger", help="the client id")) -> None:
    """Subscribe to ROBOT's sensor streams, write CSVs with timestamps, print min/max/mean/rate per channel."""
    from fleet.agent import Agent
    from sim.errors import FleetError

    wanted = [s.strip() for s in streams.split(",") if s.strip()]
    if bad := [s for s in wanted if s not in STREAMS]:
        typer.echo(f"error: unknown stream(s) {', '.join(bad)} (streams: {', '.join(STREAMS)})", err=True)
        raise typer.Exit(2)
    out.mkdir(parents=True, exist_ok=True)
    channels = {s: Channel(out / f"{s}.csv") for s in wanted}
    inbox: queue.SimpleQueue[tuple[str, bytes]] = queue.SimpleQueue()
    try:
        with Agent(agent_id, connect=connect, world=world) as agent:
            subs = [agent.session.declare_subscriber(agent.keys.robot(robot, s), _to(inbox, s)) for s in wanted]
            typer.echo(f"logging {robot} ({', '.join(wanted)}) on world '{agent.keys.world}' to {out}")
            try:
                _record(inbox, channels, duration, idle_timeout)
            except KeyboardInterrupt:
                pass
            finally:
                for sub in subs:
                    sub.undeclare()
    except FleetError as exc:
        typer.echo(f"error: {exc.message}" + (f" ({exc.hint})" if exc.hint else ""), err=True)
        raise typer.Exit(2) from exc
    finally:
        for ch in channels.values():
            ch.close()
    _report(channels, out)
    if not any(ch.rows for ch in channels.values()):
        raise typer.Exit(1)


def _to(inbox: queue.SimpleQueue[tuple[str, bytes]], stream: str) -> Callable[[Any], None]:
    """A subscriber callback (on Zenoh's thread): hand the payload over, decode on the main thread."""
    return lambda sample: inbox.put((stream, sample.payload.to_bytes()))


def _record(inbox: queue.SimpleQueue[tuple[str, bytes]], channels: dict[str, Channel], duration: float | None,
            idle_timeout: float) -> None:
    start: float | None = None
    last_data = time.monotonic()
    while True:
        try:
            stream, payload = inbox.get(timeout=0.2)
        except queue.Empty:
            if time.monotonic() - last_data > idle_timeout:
                typer.echo(f"no data for {idle_timeout:g} s: stopping (is the world running?)", err=True)
                return
            continue
        last_data = time.monotonic()
        row = row_of(stream, payload)
        start = row["stamp"] if start is None else start
        if row["stamp"] < start:
            continue  # older than the window (another stream's message overtook it)
        if duration is not None and row["stamp"] >= start + duration - 1e-9:
            if row["stamp"] >= start + duration + 0.5:  # every stream is past the window: done
                return
            continue
        channels[stream].write(row)


def _report(channels: dict[str, Channel], out: Path) -> None:
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"sensor statistics ({out})")
    for col in ("channel", "rows", "rate Hz", "field", "min", "max", "mean"):
        table.add_column(col)
    with (out / "stats.csv").open("w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(["channel", "rows", "rate_hz", "field", "min", "max", "mean"])
        for name, ch in channels.items():
            for k, (field, lo, hi, mean) in enumerate(ch.stats() or [("-", math.nan, math.nan, math.nan)]):
                w.writerow([name, ch.rows, ch.rate, field, lo, hi, mean])
                table.add_row(name if k == 0 else "", str(ch.rows) if k == 0 else "",
                              f"{ch.rate:.2f}" if k == 0 else "", field, f"{lo:.4g}", f"{hi:.4g}", f"{mean:.4g}")
    Console().print(table)
