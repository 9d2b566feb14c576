"""`alcove user create|list` and `alcove token create` (console entry point, real database)."""

from __future__ import annotations

import json
import uuid

from typer.testing import CliRunner


def test_user_and_token_commands(api_settings: None, client) -> None:
    from alcove_worker.cli.main import app

    runner = CliRunner()
    email = f"cli-{uuid.uuid4().hex[:8]}@example.org"
    made = runner.invoke(
        app, ["user", "create", email, "--admin", "--name", "CLI"], env={"ALCOVE_NEW_USER_PASSWORD": "cli password 1"}
    )
    assert made.exit_code == 0, made.output
    again = runner.invoke(app, ["user", "create", email], env={"ALCOVE_NEW_USER_PASSWORD": "cli password 1"})
    assert again.exit_code == 2 and "email:" in again.output
    short = runner.invoke(app, ["user", "create", "x-" + email], env={"ALCOVE_NEW_USER_PASSWORD": "short"})
    assert short.exit_code == 2 and "password" in short.output
    listed = json.loads(runner.invoke(app, ["user", "list", "--json"]).output)
    assert any(u["email"] == email and u["role"] == "admin" for u in listed)
    token = runner.invoke(app, ["token", "create", email, "--name", "ci"])
    assert token.exit_code == 0, token.output
    me = client.get("/api/v1/me", headers={"Authorization": f"Bearer {token.output.strip()}"})
    assert me.status_code == 200 and me.json()["email"] == email and me.json()["role"] == "admin"
    assert runner.invoke(app, ["token", "create", "nobody@example.org"]).exit_code == 2
