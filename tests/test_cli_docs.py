"""The committed CLI reference ``docs/cli.md`` is what ``scripts/gen_cli_docs.py`` generates
from the Typer app now (regenerate it after changing a command)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def _generator():
    spec = importlib.util.spec_from_file_location("gen_cli_docs", REPO / "scripts" / "gen_cli_docs.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_cli_reference_is_up_to_date() -> None:
    text = _generator().render()
    committed = (REPO / "docs" / "cli.md").read_text()
    assert committed == text, "docs/cli.md is out of date: run .venv/bin/python scripts/gen_cli_docs.py"


def test_cli_reference_covers_every_command() -> None:
    import typer.main

    from alcove_worker.cli.main import app

    text = _generator().render()
    root = typer.main.get_command(app)
    for name, command in root.commands.items():
        assert f"`alcove {name}`" in text, name
        for sub in getattr(command, "commands", {}):
            assert f"`alcove {name} {sub}`" in text, f"{name} {sub}"
