"""`alcove surrogate ...` commands."""

from __future__ import annotations

import typer

app = typer.Typer(help="surrogate commands", no_args_is_help=True)
