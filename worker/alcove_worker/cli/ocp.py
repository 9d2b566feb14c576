"""`alcove ocp ...` commands."""

from __future__ import annotations

import typer

app = typer.Typer(help="ocp commands", no_args_is_help=True)
