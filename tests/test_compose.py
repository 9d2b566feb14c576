"""docker-compose.yml and the Dockerfile cannot run here (no Docker engine), so check
what can be checked: the files parse, every command they run exists in the project with
valid options, every ALCOVE_* variable is a real setting, and what they copy exists."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import click
import pytest
import typer
import yaml

from alcove.settings import Settings
from alcove_worker.cli.main import app as cli_app

REPO = Path(__file__).resolve().parents[1]
COMPOSE = yaml.safe_load((REPO / "docker-compose.yml").read_text())
DOCKERFILE = (REPO / "Dockerfile").read_text()
PROJECT_SERVICES = {name: svc for name, svc in COMPOSE["services"].items() if "build" in svc}
THIRD_PARTY_BINARIES = {"pg_isready", "redis-cli", "redis-server", "python"}


def _usage_error_types() -> tuple[type[BaseException], ...]:
    """Click's UsageError (typer may vendor its own copy of click)."""
    types: list[type[BaseException]] = [click.UsageError]
    try:
        from typer._click.exceptions import UsageError as TyperUsageError  # typer >= 0.2x vendors click

        types.append(TyperUsageError)
    except ImportError:
        pass
    return tuple(types)


def validate_alcove_command(argv: list[str]) -> None:
    """Resolve ``alcove <group> <command> [options]`` against the real CLI and parse its
    options and arguments exactly as a run would (without running it)."""
    assert argv[0] == "alcove", argv
    cmd = typer.main.get_command(cli_app)
    ctx = cmd.make_context("alcove", [argv[1]] if len(argv) > 1 else [], resilient_parsing=True)
    args = argv[1:]
    while hasattr(cmd, "list_commands"):  # a group
        assert args, f"{argv}: missing subcommand"
        sub = cmd.get_command(ctx, args[0])
        assert sub is not None, f"{argv}: no such command {args[0]!r} (have {sorted(cmd.list_commands(ctx))})"
        cmd, args = sub, args[1:]
        ctx = type(ctx)(cmd, info_name=sub.name, parent=ctx)
    try:
        cmd.make_context(cmd.name or "", list(args), parent=ctx)
    except _usage_error_types() as err:
        pytest.fail(f"{shlex.join(argv)}: {err.format_message()}")


def test_compose_parses_with_the_expected_services() -> None:
    assert {"postgres", "redis", "api", "worker-default", "worker-ocp", "worker-oracle", "worker-train"} <= set(
        COMPOSE["services"]
    )
    for name, svc in COMPOSE["services"].items():
        for dep in svc.get("depends_on", {}):
            assert dep in COMPOSE["services"], f"{name} depends on unknown {dep}"


def test_every_project_command_exists() -> None:
    assert PROJECT_SERVICES
    for name, svc in PROJECT_SERVICES.items():
        command = svc.get("command")
        assert isinstance(command, list), f"{name}: use the exec (list) form"
        validate_alcove_command(command)


def test_workers_cover_every_queue_and_api_migrates() -> None:
    from alcove.jobs import QUEUES

    served = set()
    for svc in PROJECT_SERVICES.values():
        cmd = svc["command"]
        if cmd[1] == "worker":
            served |= set(cmd[cmd.index("--queues") + 1].split(","))
    assert served == set(QUEUES)
    api = COMPOSE["services"]["api"]["command"]
    assert api[:2] == ["alcove", "up"] and "--no-migrate" not in api  # `up` migrates before serving


def test_healthchecks_use_available_binaries() -> None:
    for name, svc in COMPOSE["services"].items():
        test = svc.get("healthcheck", {}).get("test")
        if not test:
            continue
        assert test[0] in ("CMD", "CMD-SHELL"), name
        assert test[1] in THIRD_PARTY_BINARIES, f"{name}: {test[1]} is not available in its image"


def test_alcove_environment_variables_are_settings() -> None:
    fields = {f"ALCOVE_{f.upper()}" for f in Settings.model_fields} | {"ALCOVE_MIGRATIONS_DIR"}
    envs = [svc.get("environment", {}) for svc in PROJECT_SERVICES.values()]
    names = {k for env in envs for k in env if k.startswith("ALCOVE_")}
    names |= set(re.findall(r"\b(ALCOVE_[A-Z_]+)=", DOCKERFILE))
    assert names and names <= fields, f"unknown settings: {sorted(names - fields)}"
    for env in envs:
        assert env["ALCOVE_DATABASE_URL"].startswith("postgresql+psycopg://")
        assert env["ALCOVE_BROKER_URL"].startswith("redis://")


def test_dockerfile_copies_existing_paths_and_runs_real_commands() -> None:
    for line in DOCKERFILE.splitlines():
        if line.startswith("COPY") and "--from=" not in line:
            for src in line.split()[1:-1]:
                assert (REPO / src.rstrip("/")).exists(), f"Dockerfile copies missing {src}"
        m = re.match(r"CMD (\[.*\])", line)
        if m:
            import json

            argv = json.loads(m.group(1))
            validate_alcove_command(argv)
    assert re.search(r"torch==2\.13\.0", DOCKERFILE), "the image must install the pinned torch"
