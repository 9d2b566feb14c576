"""`alcove user create|list` and `alcove token create`: accounts and API tokens from the
command line (for the first users, scripts and CI), against the configured database."""

from __future__ import annotations

import json
from typing import NoReturn, TypedDict

import typer

user_app = typer.Typer(help="User accounts (admin / member).", no_args_is_help=True)
token_app = typer.Typer(help="Personal API tokens.", no_args_is_help=True)


class _UserRow(TypedDict):
    """A user as `alcove user list` prints it (and its --json)."""

    id: int
    email: str
    role: str
    active: bool
    last_login_at: str | None


def _fail(field: str, reason: str) -> NoReturn:
    typer.echo(f"error: {field}: {reason}", err=True)
    raise typer.Exit(2)


@user_app.command("create")
def create_user(
    email: str = typer.Argument(..., help="e-mail (the login name)"),
    password: str = typer.Option(
        ...,
        prompt=True,
        hide_input=True,
        confirmation_prompt=True,
        envvar="ALCOVE_NEW_USER_PASSWORD",
        help="at least 8 characters",
    ),
    admin: bool = typer.Option(False, "--admin", help="role admin (default: member)"),
    name: str = typer.Option("", "--name", help="display name"),
) -> None:
    """Create a user."""
    from pydantic import ValidationError

    from alcove.db import session_scope
    from alcove.errors import Conflict
    from alcove.users import service
    from alcove.users.schemas import UserCreate

    try:
        body = UserCreate(email=email, password=password, display_name=name, role="admin" if admin else "member")
    except ValidationError as err:
        e = err.errors()[0]
        _fail(".".join(map(str, e["loc"])) or "user", e["msg"])
    try:
        with session_scope() as s:
            user = service.create_user(s, body)
            uid, role = user.id, user.role
    except Conflict as err:
        _fail("email", err.message)
    typer.echo(f"created user {uid} {body.email} ({role})")


@user_app.command("list")
def list_users(as_json: bool = typer.Option(False, "--json", help="print JSON")) -> None:
    """List users."""
    from rich.console import Console
    from rich.table import Table

    from alcove.db import session_scope
    from alcove.users import repository

    with session_scope() as s:
        rows: list[_UserRow] = [
            {
                "id": u.id,
                "email": u.email,
                "role": u.role,
                "active": u.is_active,
                "last_login_at": u.last_login_at.isoformat() if u.last_login_at else None,
            }
            for u in repository.list_users(s)
        ]
    if as_json:
        typer.echo(json.dumps(rows))
        return
    table = Table("id", "email", "role", "active", "last login")
    for r in rows:
        table.add_row(str(r["id"]), r["email"], r["role"], "yes" if r["active"] else "no", r["last_login_at"] or "-")
    Console().print(table)


@token_app.command("create")
def create_token(
    email: str = typer.Argument(..., help="the user the token belongs to"),
    name: str = typer.Option("cli", "--name", help="what the token is for"),
    expires_in_days: int | None = typer.Option(
        None, "--expires-in-days", min=1, max=3650, help="default: does not expire"
    ),
) -> None:
    """Create a personal API token and print it (only now: just its hash is stored)."""
    from alcove.db import session_scope
    from alcove.users import repository, service

    with session_scope() as s:
        user = repository.user_by_email(s, email)
        if user is None or not user.is_active:
            _fail("email", f"no active user {email}")
        _, secret = service.create_token(s, user, name, expires_in_days)
    typer.echo(secret)
