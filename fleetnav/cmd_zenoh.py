"""`fleetnav zenoh`: serve a world over the Zenoh API (robot agents in other processes or machines)."""

from __future__ import annotations

from pathlib import Path

import typer


def zenoh(world: str = typer.Option("robot_arena", help="world name in configs/worlds or an SDF path"),
          config: Path = typer.Option(Path("configs/zenoh/local.yaml"), help="Zenoh config (see configs/zenoh)"),
          speed: float = typer.Option(1.0, min=0.01, max=1000.0, help="real-time factor"),
          seed: int = typer.Option(0), fidelity: str = typer.Option("kinematic")) -> None:
    """Run the world in real time × speed and serve it on Zenoh until Ctrl-C (keys: docs/zenoh-api.md)."""
    import logging

    from fleet import FleetConfig, FleetService
    from fleet.zenoh_bridge import serve
    from fleet.zenoh_config import load_zenoh_config
    from sim.errors import FleetError

    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(message)s")
    try:
        cfg = load_zenoh_config(config)
        svc = FleetService(FleetConfig.model_validate({"world": world, "seed": seed, "fidelity": fidelity}))
    except FleetError as exc:
        typer.echo(f"error: {exc.message}" + (f" ({exc.hint})" if exc.hint else ""), err=True)
        raise typer.Exit(2) from exc
    with svc:
        serve(svc, cfg, speed=speed)
