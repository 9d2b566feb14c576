"""Job limits: the administrator sets them (API and command line); a campaign, surrogate config or
preview above the limits of its user is refused with a 422 naming the field, the value and the
limit, at create, at edit and at start."""

from __future__ import annotations

import json

from typer.testing import CliRunner

from tests.helpers import make_account, small_task_spec

API = "/api/v1"


def _problem(r, field: str) -> str:
    assert r.status_code == 422, r.text
    (problem,) = [p for p in r.json()["detail"] if p["field"] == field]
    return problem["msg"]


def test_defaults_bind_members_not_admins_and_only_an_admin_sets_limits(client, admin) -> None:
    from alcove.models import DEFAULT_JOB_LIMITS

    member = make_account("member", "limits")
    defaults = client.get(f"{API}/admin/job-limits", headers=admin.headers).json()
    assert {k: defaults[k] for k in DEFAULT_JOB_LIMITS} == DEFAULT_JOB_LIMITS and defaults["source"] == "defaults"
    mine = client.get(f"{API}/me/job-limits", headers=member.headers).json()
    assert mine == defaults
    assert client.get(f"{API}/me/job-limits", headers=admin.headers).json()["source"] == "none"
    assert client.patch(f"{API}/admin/job-limits", json={"max_epochs": 5}, headers=member.headers).status_code == 403
    assert client.get(f"{API}/users/{member.id}/job-limits", headers=member.headers).status_code == 403
    r = client.patch(f"{API}/users/{member.id}/job-limits", json={"max_epochs": 0}, headers=admin.headers)
    assert _problem(r, "max_epochs")
    r = client.patch(f"{API}/users/{member.id}/job-limits", json={"max_epochs": 50}, headers=admin.headers)
    assert r.status_code == 200 and r.json()["source"] == "own" and r.json()["max_epochs"] == 50
    assert r.json()["max_running_campaigns"] == DEFAULT_JOB_LIMITS["max_running_campaigns"]
    reset = client.delete(f"{API}/users/{member.id}/job-limits", headers=admin.headers).json()
    assert reset == defaults


def test_an_over_size_campaign_surrogate_config_or_preview_is_refused_naming_field_value_and_limit(
    client, admin
) -> None:
    member = make_account("member", "sizes")
    h = member.headers
    limits = {"max_preliminary_samples": 500, "max_ocp_intervals": 40, "max_ensemble_size": 2, "max_epochs": 100}
    r = client.patch(f"{API}/users/{member.id}/job-limits", json=limits, headers=admin.headers)
    assert r.status_code == 200, r.text
    task = client.post(f"{API}/tasks", json={"name": "sizes", "spec": small_task_spec()}, headers=h).json()
    oracle = client.post(f"{API}/oracles/presets/aux-penalty/copy", headers=h).json()

    # surrogate configs: at create and at edit
    big = {"ensemble_size": 3, "max_epochs": 100}
    r = client.post(f"{API}/surrogate-configs", json={"name": "big", "spec": big}, headers=h)
    assert (
        _problem(r, "spec.ensemble_size")
        == "3 is above your limit of 2 (max_ensemble_size); ask an administrator to raise it"
    )
    r = client.post(
        f"{API}/surrogate-configs", json={"name": "ok", "spec": {"ensemble_size": 2, "max_epochs": 100}}, headers=h
    )
    assert r.status_code == 201, r.text
    sc = r.json()
    r = client.put(
        f"{API}/surrogate-configs/{sc['id']}", json={"spec": {"ensemble_size": 2, "max_epochs": 1000}}, headers=h
    )
    assert "1000 is above your limit of 100 (max_epochs)" in _problem(r, "spec.max_epochs")

    # campaigns: at create, at edit and at start
    body = {
        "name": "sizes",
        "task_id": task["id"],
        "oracle_id": oracle["id"],
        "surrogate_config_id": sc["id"],
        "preliminary": {"samples": 1000},
        "settings": {"ocp_intervals": 30},
    }
    r = client.post(f"{API}/campaigns", json=body, headers=h)
    assert "1000 is above your limit of 500 (max_preliminary_samples)" in _problem(r, "preliminary.samples")
    # every problem at once, and the form's check says the same before anything is created
    over = {**body, "settings": {"ocp_intervals": 50}}
    r = client.post(f"{API}/campaigns", json=over, headers=h)
    assert sorted(p["field"] for p in r.json()["detail"]) == ["preliminary.samples", "settings.ocp_intervals"]
    report = client.post(f"{API}/campaigns/check", json=over, headers=h).json()
    assert report["valid"] is False
    assert {e["field"]: e["msg"] for e in report["errors"]}["settings.ocp_intervals"].startswith(
        "50 is above your limit of 40 (max_ocp_intervals)"
    )
    r = client.post(f"{API}/campaigns", json={**body, "preliminary": {"samples": 400}}, headers=h)
    assert r.status_code == 201, r.text
    cid = r.json()["id"]
    r = client.patch(f"{API}/campaigns/{cid}/config", json={"settings": {"ocp_intervals": 60}}, headers=h)
    assert "60 is above your limit of 40 (max_ocp_intervals)" in _problem(r, "settings.ocp_intervals")
    client.patch(f"{API}/users/{member.id}/job-limits", json={"max_ocp_intervals": 20}, headers=admin.headers)
    r = client.post(f"{API}/campaigns/{cid}/start", headers=h)
    assert "30 is above your limit of 20 (max_ocp_intervals)" in _problem(r, "settings.ocp_intervals")
    assert client.get(f"{API}/campaigns/{cid}", headers=h).json()["campaign"]["status"] == "draft"

    # the task's own intervals, when the campaign sets none
    fine = client.post(f"{API}/tasks", json={"name": "fine grid", "spec": small_task_spec(30)}, headers=h).json()
    r = client.post(
        f"{API}/campaigns",
        json={**body, "task_id": fine["id"], "preliminary": {"samples": 400}, "settings": {}},
        headers=h,
    )
    assert _problem(r, "settings.ocp_intervals").startswith("30 (the task's, per phase) is above your limit of 20")

    # previews
    r = client.post(f"{API}/tasks/{task['id']}/previews", json={"intervals": 30}, headers=h)
    assert "30 is above your limit of 20 (max_ocp_intervals)" in _problem(r, "intervals")


def test_the_command_line_shows_and_sets_limits(client, admin) -> None:
    from alcove_worker.cli.main import app

    member = make_account("member", "cli-limits")
    runner = CliRunner()
    got = runner.invoke(
        app, ["user", "limits", member.email, "--max-running-campaigns", "2", "--max-epochs", "none", "--json"]
    )
    assert got.exit_code == 0, got.output
    shown = json.loads(got.output)
    assert shown["source"] == "own" and shown["max_running_campaigns"] == 2 and shown["max_epochs"] is None
    api = client.get(f"{API}/users/{member.id}/job-limits", headers=admin.headers).json()
    assert api == shown
    bad = runner.invoke(app, ["user", "limits", member.email, "--max-epochs", "lots"])
    assert bad.exit_code == 2 and "max_epochs" in bad.output
    text = runner.invoke(app, ["user", "limits"]).output
    assert "every member (defaults)" in text and "max_running_campaigns" in text
    reset = json.loads(runner.invoke(app, ["user", "limits", member.email, "--reset", "--json"]).output)
    assert reset["source"] == "defaults"
