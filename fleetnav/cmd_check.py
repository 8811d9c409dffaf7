"""`fleetnav check world|robot FILE`: grade a course artefact, one rubric line per item."""

from __future__ import annotations

import json
from pathlib import Path

import typer

check_app = typer.Typer(add_completion=False, no_args_is_help=True,
                        help="Grade a student's world or robot against the course requirements.")


def _print(report: object, as_json: bool) -> int:
    from rich.console import Console
    from rich.table import Table

    from fleet.grading import RubricReport

    assert isinstance(report, RubricReport)
    if as_json:
        typer.echo(json.dumps(report.to_dict(), indent=2))
    else:
        table = Table(title=f"{report.title}: {report.earned:g}/{report.total:g} points")
        for col in ("", "item", "measured", "expected", "points"):
            table.add_column(col)
        for i in report.items:
            table.add_row("[green]PASS[/green]" if i.passed else "[red]FAIL[/red]", i.description, i.measured,
                          i.expected, f"{i.earned:g}/{i.points:g}")
        console = Console()
        console.print(table)
        for note in report.notes:
            console.print(f"note: {note}")
    return 0 if report.passed else 1


def _run(kind: str, file: Path, as_json: bool) -> None:
    from fleet.grading import check_robot, check_world
    from sim.errors import FleetError

    try:
        report = check_world(file) if kind == "world" else check_robot(file)
    except FleetError as exc:
        typer.echo(f"error: {exc.message}" + (f" ({exc.hint})" if exc.hint else ""), err=True)
        raise typer.Exit(2) from exc
    raise typer.Exit(_print(report, as_json))


@check_app.command("world")
def world(file: Path = typer.Argument(..., help="SDF .world file"),
          as_json: bool = typer.Option(False, "--json", help="print the report as JSON")) -> None:
    """Custom Gazebo World rubric (15 points). Exit 0 only if every item passes."""
    _run("world", file, as_json)


@check_app.command("robot")
def robot(file: Path = typer.Argument(..., help="URDF file"),
          as_json: bool = typer.Option(False, "--json", help="print the report as JSON")) -> None:
    """Robot Model (25 points) and Gazebo Plugins (20 points) rubric. Exit 0 only if every item passes."""
    _run("robot", file, as_json)
