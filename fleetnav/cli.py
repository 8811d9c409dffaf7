"""The `fleetnav` command line. Heavy imports live inside each command so `fleetnav --help` is instant."""

from __future__ import annotations

import typer

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="fleetnav: multi-robot fleet and navigation orchestration over a PyBullet world.")


@app.command()
def demo(
    world: str = typer.Option("robot_arena", help="a shipped world name or an SDF world file"),
    robots: int = typer.Option(3, min=1, max=50, help="robots to spawn"),
    seconds: float = typer.Option(20.0, min=0.1, help="sim seconds to run"),
    fidelity: str = typer.Option("kinematic", help="kinematic or dynamic"),
    seed: int = typer.Option(0),
) -> None:
    """Headless demo: load a world, spawn robots, drive them, print what happened."""
    from fleet.paths import world_file
    from fleetnav.demo import run_demo
    from sim.errors import FleetError

    try:
        path = world_file(world)
    except FleetError as exc:
        typer.echo(f"error: {exc.message} ({exc.hint})", err=True)
        raise typer.Exit(2) from exc
    raise typer.Exit(run_demo(path, robots=robots, seconds=seconds, fidelity=fidelity, seed=seed))


@app.command()
def version() -> None:
    """Print the installed fleetnav version."""
    from importlib.metadata import version as v

    typer.echo(v("fleetnav"))


from fleetnav.cmd_check import check_app  # noqa: E402  (typer sub-app; its commands import lazily)

app.add_typer(check_app, name="check")


from fleetnav.cmd_missions import register as _register_missions  # noqa: E402  (run, validate, replay, diff)

_register_missions(app)

from fleetnav.cmd_serve import register as _register_serve  # noqa: E402  (serve: the MCP server)

_register_serve(app)

from fleetnav.cmd_challenge import challenge_app  # noqa: E402  (challenge run|leaderboard|arenas|list)
from fleetnav.cmd_log import log as _log  # noqa: E402
from fleetnav.cmd_teleop import teleop as _teleop  # noqa: E402

app.add_typer(challenge_app, name="challenge")
app.command("teleop")(_teleop)
app.command("log")(_log)

from fleetnav.cmd_zenoh import zenoh as _zenoh  # noqa: E402

app.command("zenoh")(_zenoh)

from fleetnav.cmd_slam import slam_app  # noqa: E402  (slam run|eval: SLAM on recorded logs)

app.add_typer(slam_app, name="slam")


def main() -> None:
    app()


if __name__ == "__main__":
    main()

from fleetnav.cmd_barn import barn_app  # noqa: E402  (barn run: the BARN benchmark suite)

app.add_typer(barn_app, name="barn")
