"""`fleetnav zenoh`: serve a world over the Zenoh API (robot agents in other processes or machines).

One command to get a world to drive, from any folder:

    fleetnav zenoh --world robot_arena --spawn r1@spawn_start --spawn r2@1,-2,0 --live &
    python examples/goal_seeker.py --connect tcp/127.0.0.1:7447 --robot r1 --goal 5 5

Exit codes: 0 clean shutdown (Ctrl-C), 2 bad input (one line on stderr).
"""

from __future__ import annotations

from typing import Any

import typer

EXIT_INPUT = 2


def zenoh(
    world: str = typer.Option("robot_arena", "--world", help="a shipped world name or an SDF file"),
    config: str = typer.Option("local", "--config", help="Zenoh config: a YAML file or a shipped name "
                               "(local, lan, secure, lockstep, ros2; see configs/zenoh)"),
    spawn: list[str] = typer.Option([], "--spawn", help="NAME@spawn_point or NAME@x,y[,yaw] (repeatable); "
                                    "NAME alone: the world's first spawn point. Default: r1 at the first one"),
    empty: bool = typer.Option(False, "--empty", help="spawn no robot (agents spawn their own)"),
    robot: str | None = typer.Option(None, "--robot", help="robot model for --spawn (a name in configs/robots or "
                                     "a robot file); default: the fleet's"),
    speed: float = typer.Option(1.0, "--speed", min=0.01, max=1000.0, help="real-time factor"),
    seed: int = typer.Option(0, "--seed"),
    fidelity: str = typer.Option("kinematic", "--fidelity", help="kinematic or dynamic"),
    control_hz: float | None = typer.Option(None, "--control-hz", min=1, max=200,
                                            help="control rate (Hz); default: the Zenoh config's, else 10"),
    odom_hz: float | None = typer.Option(None, "--odom-hz", min=0.1, max=1000,
                                         help="publish odom at most this often; default: every reading"),
    state_hz: float | None = typer.Option(None, "--state-hz", min=0.1, max=200,
                                          help="publish pose/state at most this often (≤ control rate)"),
    live: bool = typer.Option(False, "--live", help="also serve a Foxglove WebSocket live view"),
    live_port: int = typer.Option(8765, "--live-port", min=0, max=65535),
) -> None:
    """Run a world in real time × speed and serve it on Zenoh until Ctrl-C (keys: docs/zenoh-api.md)."""
    import logging

    from sim.errors import FleetError

    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(message)s")
    if empty and spawn:
        _fail("--empty and --spawn contradict each other")
    if fidelity not in ("kinematic", "dynamic"):
        _fail(f"--fidelity must be kinematic or dynamic, got '{fidelity}'")
    built: list[Any] = []
    try:
        spawns = [] if empty else (spawn or ["r1"])
        svc, cfg = _build(world, config, spawns, robot, seed, fidelity, control_hz, odom_hz, state_hz, built)
    except FleetError as exc:
        for b in reversed(built):
            b.close()
        _fail(f"{exc.code.value}: {exc.message}" + (f" ({exc.hint})" if exc.hint else ""))
    from fleet.zenoh_bridge import serve

    view = None
    if live:
        from fleet.live_view import LiveView

        view = LiveView(port=live_port).attach(svc)
        typer.echo(f"live view: {view.url} (Foxglove → Open connection)", err=True)
    with svc:
        try:
            serve(svc, cfg, speed=speed, on_ready=lambda ep: _ready(ep, svc.robot_names()))
        finally:
            if view is not None:
                view.close()


def _build(world: str, config: str, spawn: list[str], robot: str | None, seed: int, fidelity: str,
           control_hz: float | None, odom_hz: float | None, state_hz: float | None, built: list[Any]) -> Any:
    from fleet import FleetConfig, FleetService
    from fleet.zenoh_bridge.setup import resolve_spawns, zenoh_config_file
    from fleet.zenoh_config import load_zenoh_config

    cfg = load_zenoh_config(zenoh_config_file(config))
    rates = {k: v for k, v in (("control_hz", control_hz), ("odom_hz", odom_hz), ("state_hz", state_hz))
             if v is not None}
    cfg = cfg.model_validate(cfg.model_dump() | rates)  # validated again: flags obey the file's bounds
    fleet: dict[str, Any] = {"world": world, "seed": seed, "fidelity": fidelity}
    if cfg.control_hz is not None:
        fleet["control_hz"] = cfg.control_hz
    if robot is not None:
        fleet["robot_model"] = robot
    svc = FleetService(FleetConfig.model_validate(fleet))
    built.append(svc)
    cfg.check_rates(svc.config.control_hz)
    from sim.types import Pose2D

    for name, pose in resolve_spawns(spawn, svc.world.description):
        svc.spawn_robot(name, Pose2D(pose.x, pose.y, pose.yaw))
    return svc, cfg


def _ready(endpoints: list[str], robots: list[str]) -> None:
    ep = endpoints[0] if endpoints else "<endpoint>"
    listing = ", ".join(robots) if robots else "none yet (agents can spawn them, or use --spawn NAME@x,y,yaw)"
    typer.echo(f"ready on {', '.join(endpoints) or '(peer discovery)'}; robots: {listing}", err=True)
    if robots:
        typer.echo(f"  try: python examples/goal_seeker.py --connect {ep} --robot {robots[0]} --goal 5 5", err=True)


def _fail(message: str) -> None:
    typer.echo(f"error: {message}", err=True)
    raise typer.Exit(EXIT_INPUT)
