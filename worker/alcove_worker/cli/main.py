"""The ``alcove`` command line. Each command group lives in its own module."""

from __future__ import annotations

import typer

from alcove_worker.cli import campaign, db, ocp, oracle, serve, surrogate, surrogate_compare, users

app = typer.Typer(
    name="alcove", help="Active-learning campaigns for contact surrogates.", no_args_is_help=True, add_completion=False
)
app.add_typer(ocp.app, name="ocp")
app.add_typer(oracle.app, name="oracle")
surrogate.app.command(name="compare")(surrogate_compare.compare)
app.add_typer(surrogate.app, name="surrogate")
app.add_typer(db.app, name="db")
app.add_typer(campaign.app, name="campaign")
app.add_typer(users.user_app, name="user")
app.add_typer(users.token_app, name="token")
app.command(name="up")(serve.up)
app.command(name="serve")(serve.serve)
app.command(name="worker")(serve.worker)
app.command(name="smoke")(serve.smoke)


@app.command()
def version() -> None:
    """Print the alcove version."""
    import alcove

    typer.echo(alcove.__version__)


if __name__ == "__main__":
    app()
