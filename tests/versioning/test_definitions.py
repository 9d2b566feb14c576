"""Tasks and oracles over HTTP: versioning, presets, validation with field paths, JSON
Schemas, sharing, the command catalogue, body limits."""

from __future__ import annotations

import sqlalchemy as sa

from tests.helpers import Account, small_task_spec, unique

API = "/api/v1"


def create_task(client, who: Account, **over) -> dict:
    body = {"name": unique("task"), "description": "", "spec": small_task_spec(), **over}
    r = client.post(f"{API}/tasks", json=body, headers=who.headers)
    assert r.status_code == 201, r.text
    return r.json()


def lock_latest_version(task_id: int) -> None:
    """What the campaign engine does when a campaign starts using a version."""
    from alcove.db import open_transaction
    from alcove.models import TaskDefinition, TaskVersion, utcnow

    with open_transaction() as s:
        d = s.get(TaskDefinition, task_id)
        v = s.scalar(
            sa.select(TaskVersion).where(TaskVersion.definition_id == task_id, TaskVersion.version == d.latest_version)
        )
        v.locked_at = utcnow()


def test_task_edit_is_in_place_until_used_then_a_new_version(client, owner: Account) -> None:
    task = create_task(client, owner)
    assert task["version"] == 1 and not task["version_locked"] and task["n_phases"] == 2
    spec = task["spec"]
    spec["phases"][0]["duration"] = 0.8
    r = client.put(f"{API}/tasks/{task['id']}", json={"spec": spec}, headers=owner.headers)
    assert r.status_code == 200 and r.json()["version"] == 1 and r.json()["spec"]["phases"][0]["duration"] == 0.8
    lock_latest_version(task["id"])
    spec["phases"][0]["duration"] = 0.7
    r = client.put(f"{API}/tasks/{task['id']}", json={"spec": spec, "note": "shorter approach"}, headers=owner.headers)
    assert r.status_code == 200 and r.json()["version"] == 2 and not r.json()["version_locked"]
    versions = client.get(f"{API}/tasks/{task['id']}/versions", headers=owner.headers).json()
    assert [(v["version"], v["locked"], v["spec"]["phases"][0]["duration"]) for v in versions] == [
        (1, True, 0.8),
        (2, False, 0.7),
    ]
    # the same content again: no new version
    r = client.put(f"{API}/tasks/{task['id']}", json={"spec": spec, "name": "renamed"}, headers=owner.headers)
    assert r.json()["version"] == 2 and r.json()["name"] == "renamed"


def test_bad_task_spec_is_422_with_the_field_path(client, owner: Account) -> None:
    spec = small_task_spec()
    spec["phases"][1]["duration"] = -1
    r = client.post(f"{API}/tasks", json={"name": "bad", "spec": spec}, headers=owner.headers)
    assert r.status_code == 422
    assert any(e["field"] == "spec.phases.1.duration" and "greater than 0" in e["msg"] for e in r.json()["detail"])
    # a cross-field rule reports the field it concerns
    spec = small_task_spec()
    spec["phases"][0]["q_min"] = [0.3]
    spec["phases"][0]["q_max"] = [0.2]
    r = client.post(f"{API}/tasks", json={"name": "bad", "spec": spec}, headers=owner.headers)
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == "spec.phases.0.q_min.0", r.json()


def test_validate_reports_field_errors_without_saving(client, owner: Account) -> None:
    before = len(client.get(f"{API}/tasks", params={"limit": 1000}, headers=owner.headers).json())
    spec = small_task_spec()
    spec["phases"][1]["intervals"] = 0
    spec["initial"]["q"] = [1.0]
    r = client.post(f"{API}/tasks/check", json={"spec": spec}, headers=owner.headers)
    assert r.status_code == 200 and not r.json()["valid"]
    assert {e["field"] for e in r.json()["errors"]} >= {"spec.phases.1.intervals"}
    ok = client.post(f"{API}/tasks/check", json={"spec": small_task_spec()}, headers=owner.headers).json()
    assert ok["valid"] and ok["errors"] == [] and ok["normalized"]["model"]["mass"] == 5.0
    assert len(client.get(f"{API}/tasks", params={"limit": 1000}, headers=owner.headers).json()) == before


def test_presets_are_listed_and_copied_and_schemas_served(client, owner: Account) -> None:
    presets = client.get(f"{API}/tasks/presets", headers=owner.headers).json()
    assert [p["key"] for p in presets] == [
        "head-headrest-2phase",
        "head-headrest-smooth",
        "head-headrest-2dof",
        "head-headrest-scenarios",
    ]
    copy = client.post(f"{API}/tasks/presets/head-headrest-2phase/copy", json={"name": "mine"}, headers=owner.headers)
    assert (
        copy.status_code == 201
        and copy.json()["preset_key"] == "head-headrest-2phase"
        and copy.json()["spec"] == presets[0]["spec"]
    )
    assert client.post(f"{API}/tasks/presets/nope/copy", headers=owner.headers).status_code == 404
    schema = client.get(f"{API}/tasks/schema", headers=owner.headers).json()
    assert "phases" in schema["properties"]
    oracle_presets = {p["key"]: p for p in client.get(f"{API}/oracles/presets", headers=owner.headers).json()}
    assert set(oracle_presets) == {"aux-penalty", "fe-headrest-2d", "fe-headrest-3d-ccx"}
    assert oracle_presets["aux-penalty"]["params"]["k"] > 0
    types = {t["name"]: t for t in client.get(f"{API}/oracles/types", headers=owner.headers).json()}
    assert "friction" in types["fe-headrest-2d"]["params_schema"]["properties"]
    assert "contact_formulation" in types["fe-headrest-3d-ccx"]["params_schema"]["properties"]
    assert client.get(f"{API}/oracles/types/aux-penalty/schema", headers=owner.headers).json()["properties"]["k"]
    assert client.get(f"{API}/oracles/types/nope/schema", headers=owner.headers).status_code == 404


def test_model_presets_are_served_whole_and_each_is_a_valid_task_model(client, owner: Account) -> None:
    """The task editor loads a model preset's parameters when it is chosen: every preset of
    ``model.preset`` but the user-defined ``chain``, each with all its numbers, each accepted
    as the model of a task (1 joint: the paper's task; n joints: its phases without per-joint lists)."""
    from alcove.science.ocp.task_spec import ModelSpec

    presets = client.get(f"{API}/tasks/model-presets", headers=owner.headers).json()
    by_key = {p["key"]: p for p in presets}
    assert set(by_key) == set(ModelSpec.model_fields["preset"].annotation.__args__) - {"chain"}  # type: ignore[union-attr]
    assert by_key["head-neck-1dof"]["model"]["theta0"] == 0.232 and "chain" not in by_key["head-neck-1dof"]["model"]
    two = by_key["head-neck-2dof"]
    assert two["ndof"] == 2 and len(two["model"]["chain"]["links"]) == 2 and "mass" not in two["model"]
    assert all(j["torque_limit"] > 0 and "damping" in j for j in two["model"]["chain"]["joints"])  # defaults filled in
    base = client.get(f"{API}/tasks/presets", headers=owner.headers).json()[0]["spec"]
    for p in presets:
        report = client.post(
            f"{API}/tasks/check",
            json={"name": p["key"], "spec": {**base, "model": p["model"]}},
            headers=owner.headers,
        ).json()
        assert report["valid"], (p["key"], report["errors"])
    assert client.get(f"{API}/tasks/model-presets").status_code == 401


def test_oracle_params_are_validated_per_type(client, owner: Account) -> None:
    r = client.post(
        f"{API}/oracles", json={"name": "aux", "type": "aux-penalty", "params": {"k": 1e5}}, headers=owner.headers
    )
    assert r.status_code == 201 and r.json()["params"]["k"] == 1e5 and r.json()["params"]["d0"] == 100.0
    oid = r.json()["id"]
    bad = client.put(f"{API}/oracles/{oid}", json={"params": {"k": -1}}, headers=owner.headers)
    assert bad.status_code == 422 and bad.json()["detail"][0]["field"] == "params.k"
    unknown = client.post(f"{API}/oracles", json={"name": "x", "type": "rm -rf /", "params": {}}, headers=owner.headers)
    assert unknown.status_code == 422 and unknown.json()["detail"][0]["field"] == "type"
    extra = client.post(
        f"{API}/oracles/check", json={"type": "fe-headrest-2d", "params": {"frction": 0.3}}, headers=owner.headers
    ).json()
    assert not extra["valid"] and extra["errors"][0]["field"] == "params.frction"
    switched = client.put(f"{API}/oracles/{oid}", json={"type": "fe-headrest-2d"}, headers=owner.headers)
    assert (
        switched.status_code == 200
        and switched.json()["type"] == "fe-headrest-2d"
        and switched.json()["params"]["friction"] == 0.4
    )


def test_command_catalogue_is_admin_managed_members_pick_by_name(client, owner: Account, admin: Account) -> None:
    name = unique("solver")
    entry = {"name": name, "argv": ["/bin/true"], "description": "test solver", "timeout_s": 60}
    assert client.post(f"{API}/admin/command-oracles", json=entry, headers=owner.headers).status_code == 403
    r = client.post(f"{API}/admin/command-oracles", json=entry, headers=admin.headers)
    assert r.status_code == 201, r.text
    assert (
        client.post(
            f"{API}/admin/command-oracles", json={**entry, "name": "aux-penalty"}, headers=admin.headers
        ).status_code
        == 422
    )
    types = {t["name"]: t for t in client.get(f"{API}/oracles/types", headers=owner.headers).json()}
    assert types[name]["kind"] == "command" and "dt_out" in types[name]["params_schema"]["properties"]
    made = client.post(
        f"{API}/oracles", json={"name": "ext", "type": name, "params": {"dt_out": 0.01}}, headers=owner.headers
    )
    assert made.status_code == 201 and made.json()["params"]["dt_out"] == 0.01
    # members cannot smuggle a command line in: unknown parameters are refused
    smuggle = client.post(
        f"{API}/oracles",
        json={"name": "ext", "type": name, "params": {"argv": ["sh", "-c", "x"]}},
        headers=owner.headers,
    )
    assert smuggle.status_code == 422 and smuggle.json()["detail"][0]["field"] == "params.argv"
    disabled = client.put(
        f"{API}/admin/command-oracles/{r.json()['id']}", json={**entry, "enabled": False}, headers=admin.headers
    )
    assert disabled.status_code == 200
    assert name not in {t["name"] for t in client.get(f"{API}/oracles/types", headers=owner.headers).json()}


def test_a_duplicate_command_oracle_name_is_refused_and_nothing_changes(client, admin: Account) -> None:
    name = unique("dup-solver")
    entry = {"name": name, "argv": ["/bin/true"], "description": "first", "timeout_s": 60}
    assert client.post(f"{API}/admin/command-oracles", json=entry, headers=admin.headers).status_code == 201
    before = client.get(f"{API}/admin/command-oracles", headers=admin.headers).json()
    r = client.post(
        f"{API}/admin/command-oracles",
        json={**entry, "argv": ["/bin/false"], "description": "second", "timeout_s": 5},
        headers=admin.headers,
    )
    assert r.status_code == 409 and r.json()["detail"] == f"name: a command oracle named {name!r} exists"
    assert client.get(f"{API}/admin/command-oracles", headers=admin.headers).json() == before
    assert [(e["argv"], e["description"]) for e in before if e["name"] == name] == [(["/bin/true"], "first")]


def test_others_objects_are_404_until_shared(client, owner: Account, other: Account) -> None:
    task = create_task(client, owner)
    url = f"{API}/tasks/{task['id']}"
    assert client.get(url, headers=other.headers).status_code == 404
    assert task["id"] not in {
        t["id"] for t in client.get(f"{API}/tasks", params={"limit": 1000}, headers=other.headers).json()
    }
    share = client.post(
        f"{API}/shares",
        json={"object_type": "task", "object_id": task["id"], "email": other.email},
        headers=owner.headers,
    )
    assert share.status_code == 201, share.text
    got = client.get(url, headers=other.headers)
    assert got.status_code == 200 and not got.json()["can_edit"]
    assert client.put(url, json={"name": "hijack"}, headers=other.headers).status_code == 403
    assert client.delete(url, headers=other.headers).status_code == 403
    # the grantee cannot re-share
    assert (
        client.post(
            f"{API}/shares",
            json={"object_type": "task", "object_id": task["id"], "email": other.email},
            headers=other.headers,
        ).status_code
        == 403
    )
    client.post(
        f"{API}/shares",
        json={"object_type": "task", "object_id": task["id"], "email": other.email, "permission": "edit"},
        headers=owner.headers,
    )
    assert client.put(url, json={"name": "shared edit"}, headers=other.headers).status_code == 200
    listed = client.get(
        f"{API}/shares", params={"object_type": "task", "object_id": task["id"]}, headers=owner.headers
    ).json()
    assert [(s["email"], s["permission"]) for s in listed] == [(other.email, "edit")]
    assert client.delete(f"{API}/shares/{listed[0]['id']}", headers=owner.headers).status_code == 204
    assert client.get(url, headers=other.headers).status_code == 404


def test_delete_archives_a_used_definition(client, owner: Account) -> None:
    used = create_task(client, owner)
    lock_latest_version(used["id"])
    assert client.delete(f"{API}/tasks/{used['id']}", headers=owner.headers).status_code == 204
    assert client.get(f"{API}/tasks/{used['id']}", headers=owner.headers).json()["archived"]
    ids = {t["id"] for t in client.get(f"{API}/tasks", params={"limit": 1000}, headers=owner.headers).json()}
    assert used["id"] not in ids
    unused = create_task(client, owner)
    assert client.delete(f"{API}/tasks/{unused['id']}", headers=owner.headers).status_code == 204
    assert client.get(f"{API}/tasks/{unused['id']}", headers=owner.headers).status_code == 404


def test_oversized_and_malformed_bodies_are_4xx_not_500(client, owner: Account) -> None:
    big = {"name": "x", "type": "aux-penalty", "params": {}, "description": "y" * (9 * 1024 * 1024)}
    assert client.post(f"{API}/oracles", json=big, headers=owner.headers).status_code == 413
    r = client.post(f"{API}/tasks", content=b"{not json", headers={**owner.headers, "Content-Type": "application/json"})
    assert r.status_code == 422
    assert client.get(f"{API}/tasks/99999999999", headers=owner.headers).status_code == 422
    assert client.get(f"{API}/tasks/2147483647", headers=owner.headers).status_code == 404


def test_a_command_oracles_launcher_is_checked_at_the_field_and_kept(client, admin: Account) -> None:
    """The admin's launcher fields: a bad one is a 422 naming it; a Slurm launcher is stored with
    the values set and shown back; none (or scheduler local) is stored as NULL (on the worker)."""
    name = unique("slurm-solver")
    entry = {"name": name, "argv": ["/bin/true"], "timeout_s": 60}
    for launcher, field in (
        ({"scheduler": "slurm", "partition": "a b"}, "launcher.partition"),
        ({"scheduler": "slurm", "cpus_per_task": 0}, "launcher.cpus_per_task"),
        ({"scheduler": "slurm", "directives": {"qos": "x;y z"}}, "launcher.directives"),
        ({"scheduler": "sge"}, "launcher.scheduler"),
    ):
        r = client.post(f"{API}/admin/command-oracles", json={**entry, "launcher": launcher}, headers=admin.headers)
        assert r.status_code == 422, r.text
        assert [e["field"] for e in r.json()["detail"]] == [field], r.json()
    launcher = {"scheduler": "slurm", "partition": "short", "cpus_per_task": 4, "time_limit_s": 600}
    on_the_cluster = {**entry, "argv": ["/cluster/only/solver"], "launcher": launcher}
    r = client.post(f"{API}/admin/command-oracles", json=on_the_cluster, headers=admin.headers)
    assert r.status_code == 201, r.text
    assert r.json()["launcher"] == launcher
    # users see where it runs; its program is on the compute nodes, not looked for on the API host
    listed = {t["name"]: t for t in client.get(f"{API}/oracles/types", headers=admin.headers).json()}[name]
    assert listed["available"] and listed["launcher"] == (
        "one Slurm job per oracle call (partition short, 1 task x 4 CPU, time limit 600 s)"
    )
    local = client.put(
        f"{API}/admin/command-oracles/{r.json()['id']}",
        json={**entry, "launcher": {"scheduler": "local"}},
        headers=admin.headers,
    )
    assert local.status_code == 200 and local.json()["launcher"] is None
