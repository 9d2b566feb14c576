"""`alcove db ...`: schema migrations (Alembic is the only way the schema changes)."""

from __future__ import annotations

from typing import Any

import typer

app = typer.Typer(
    help="Database schema: upgrade, downgrade, current revision, model/migration check.", no_args_is_help=True
)


def _url_option() -> Any:  # typer.Option's marker, typed Any so that it can default a `str | None` parameter
    return typer.Option(
        None, "--url", help="SQLAlchemy URL (default: ALCOVE_DATABASE_URL or SQLite in ALCOVE_DATA_DIR)"
    )


@app.command()
def upgrade(revision: str = typer.Argument("head", help="target revision"), url: str | None = _url_option()) -> None:
    """Migrate the database up to REVISION (default: head)."""
    from alcove.db import migrate

    migrate.upgrade(url, revision)
    typer.echo(f"database at revision {migrate.current_revision(url)}")


@app.command()
def downgrade(
    revision: str = typer.Argument(..., help="target revision, e.g. -1 or base"), url: str | None = _url_option()
) -> None:
    """Migrate the database down to REVISION (``-1`` = one step, ``base`` = empty)."""
    from alcove.db import migrate

    migrate.downgrade(url, revision)
    typer.echo(f"database at revision {migrate.current_revision(url)}")


@app.command()
def current(url: str | None = _url_option()) -> None:
    """Print the database's revision and the code's head revision."""
    from alcove.db import migrate

    cur, head = migrate.current_revision(url), migrate.head_revision()
    typer.echo(f"current: {cur}\nhead:    {head}\n{'up to date' if cur == head else 'needs `alcove db upgrade`'}")


@app.command()
def check(url: str | None = _url_option()) -> None:
    """Exit 1 if the migrated database and the models differ (like `alembic check`)."""
    from alcove.db import migrate

    diff = migrate.schema_diff(url)
    if diff:
        for d in diff:
            typer.echo(str(d))
        raise typer.Exit(1)
    typer.echo("models and migrations agree")
