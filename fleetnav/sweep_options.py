"""The executor options every sweep command shares (`run`, `challenge run`, `barn run`): one definition."""

from __future__ import annotations

import typer

EXECUTOR = typer.Option("local", "--executor", help="local (process pool) or ray (pip install 'fleetnav\\[ray]')")
RAY_ADDRESS = typer.Option(None, "--ray-address", help="with --executor ray: a cluster's host:port, or auto (the "
                           "cluster on this machine); default: start a local Ray instance")
RETRIES = typer.Option(2, "--retries", min=0, max=10, help="re-runs of a run whose worker died")
