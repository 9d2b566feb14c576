"""`alcove user create|list|limits` and `alcove token create`: accounts, their job limits and API
tokens from the command line (for the first users, scripts and CI), against the configured database."""

from __future__ import annotations

import json
from typing import Any, NoReturn, TypedDict

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

    from alcove.db import open_transaction
    from alcove.errors import Conflict
    from alcove.users import service
    from alcove.users.schemas import UserCreate

    try:
        body = UserCreate(email=email, password=password, display_name=name, role="admin" if admin else "member")
    except ValidationError as err:
        e = err.errors()[0]
        _fail(".".join(map(str, e["loc"])) or "user", e["msg"])
    try:
        with open_transaction() as s:
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

    from alcove.db import open_transaction
    from alcove.users import repository

    with open_transaction() as s:
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
    from alcove.db import open_transaction
    from alcove.users import repository, service

    with open_transaction() as s:
        user = repository.user_by_email(s, email)
        if user is None or not user.is_active:
            _fail("email", f"no active user {email}")
        _, secret = service.create_token(s, user, name, expires_in_days)
    typer.echo(secret)


def _limit_value(name: str, text: str) -> int | None:
    if text.strip().lower() in ("none", "null", "unlimited"):
        return None
    try:
        value = int(text)
    except ValueError:
        _fail(name, f"{text!r} is neither a whole number nor 'none'")
    if value < 1:
        _fail(name, f"{value} is below 1 (use 'none' to lift the limit)")
    return value


def _limit_option(what: str) -> Any:
    return typer.Option(None, help=f"{what}: a whole number >= 1, or 'none' for no limit")


@user_app.command("limits")
def job_limits(
    email: str | None = typer.Argument(None, help="the user (default: the members' defaults)"),
    max_running_campaigns: str | None = _limit_option("campaigns running at once (more wait, queued)"),
    max_preliminary_samples: str | None = _limit_option("largest preliminary.samples"),
    max_ocp_intervals: str | None = _limit_option("most OCP intervals per phase (campaign settings, task, preview)"),
    max_ensemble_size: str | None = _limit_option("largest surrogate ensemble_size"),
    max_hidden_layers: str | None = _limit_option("most hidden layers of a net"),
    max_layer_width: str | None = _limit_option("most units in one hidden layer"),
    max_epochs: str | None = _limit_option("largest max_epochs / warm_max_epochs"),
    reset: bool = typer.Option(False, "--reset", help="drop the user's own limits (the defaults bind them again)"),
    as_json: bool = typer.Option(False, "--json", help="print JSON"),
) -> None:
    """Show or set job limits: the members' defaults, or a user's own (a member without limits of
    their own has the defaults; an admin without them has no limit). Options given change those
    limits; the others keep their values."""
    from alcove.db import open_transaction
    from alcove.users import limits
    from alcove.users import repository as users_repo
    from alcove.users.schemas import JobLimitsUpdate

    given = {
        name: text
        for name, text in {
            "max_running_campaigns": max_running_campaigns,
            "max_preliminary_samples": max_preliminary_samples,
            "max_ocp_intervals": max_ocp_intervals,
            "max_ensemble_size": max_ensemble_size,
            "max_hidden_layers": max_hidden_layers,
            "max_layer_width": max_layer_width,
            "max_epochs": max_epochs,
        }.items()
        if text is not None
    }
    update = JobLimitsUpdate(**{name: _limit_value(name, text) for name, text in given.items()})
    with open_transaction() as s:
        if email is None:
            if reset:
                _fail("--reset", "needs a user's e-mail (the defaults have nothing to reset to)")
            out = limits.set_defaults(s, update) if given else limits.defaults(s)
        else:
            user = users_repo.user_by_email(s, email)
            if user is None:
                _fail("email", f"no user {email}")
            if reset:
                limits.reset_own(s, user)
            out = limits.set_own(s, user, update) if given else limits.limits_of(s, user)
    if as_json:
        typer.echo(out.model_dump_json())
        return
    typer.echo(f"job limits of {email or 'every member (defaults)'} ({out.source}):")
    for name, value in out.model_dump(exclude={"source"}).items():
        typer.echo(f"  {name:26s} {'no limit' if value is None else value}")
