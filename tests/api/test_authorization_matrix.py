"""Authorization matrix over EVERY route of the app, generated from its route table: a
route without an entry in ``SPECS`` fails the test, so no new route escapes it.

Roles: anonymous (401 everywhere except health and login), the owner of the objects
(success), another member and an admin (404 for the owner's objects: they are invisible
to them; a body naming them is a 422 on the field; admin-only routes answer 403 to members)."""

from __future__ import annotations

import io
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import pytest

from tests.helpers import Account, make_account, small_task_spec

API = "/api/v1"
PUBLIC = {"health", "readiness", "login"}


@dataclass
class Call:
    path: dict[str, Any] = field(default_factory=dict)
    json: Any = None
    params: dict[str, Any] | None = None
    files: dict[str, Any] | None = None
    data: dict[str, Any] | None = None
    fresh_token: bool = False


class Objects:
    """The owner's objects, made on demand (fresh ones for calls that change or delete)."""

    def __init__(self, client, owner: Account, third: Account) -> None:
        self.client, self.owner, self.third = client, owner, third
        self._finished: dict[str, Any] | None = None

    def post(self, path: str, body: Any = None) -> dict:
        r = self.client.post(API + path, json=body, headers=self.owner.headers)
        assert r.status_code in (200, 201), (path, r.status_code, r.text)
        return r.json()

    def task(self) -> int:
        return self.post("/tasks", {"name": f"t-{uuid.uuid4().hex[:6]}", "spec": small_task_spec()})["id"]

    def oracle(self) -> int:
        return self.post("/oracles/presets/aux-penalty/copy")["id"]

    def surrogate(self) -> int:
        return self.post("/surrogate-configs", {"name": "s", "spec": {"max_epochs": 10}})["id"]

    def campaign(self, start: bool = False) -> int:
        body = {
            "name": "c",
            "task_id": self.task(),
            "oracle_id": self.oracle(),
            "stopping": {"max_iterations": 2},
            "start": start,
        }
        return self.post("/campaigns", body)["id"]

    def paused_campaign(self) -> int:
        cid = self.campaign(start=True)
        self.post(f"/campaigns/{cid}/pause")
        return cid

    def failed_campaign(self) -> int:
        from alcove.db import open_transaction
        from alcove.models import Campaign, IterationStep

        cid = self.campaign(start=True)
        with open_transaction() as s:
            c = s.get(Campaign, cid)
            step = s.query(IterationStep).filter_by(campaign_id=cid).one()
            step.status, step.error, step.attempts = "failed", "injected", step.max_attempts
            c.status, c.error, c.stop_reason = "failed", "injected", "error"
        return cid

    def finished(self) -> dict[str, Any]:
        """A completed campaign with metrics, curves, pool versions and one model version."""
        if self._finished is None:
            from alcove.db import open_transaction
            from alcove.models import ModelVersion
            from alcove.surrogates.artifact_zips import ZIP_LAYOUT, cache_dir
            from alcove.surrogates.service import model_artifact_bytes
            from tests.synthetic import synthesize_campaign

            with open_transaction() as s:
                c = synthesize_campaign(s, self.owner.id, iterations=2, model=True, name="matrix")
                self._finished = {"campaign_id": c.id}
                # this process has torch already: pre-build the artifact zip the API caches
                # (the lifecycle test covers building it in the API's child process)
                mv = s.query(ModelVersion).filter_by(campaign_id=c.id).one()
                (cache_dir() / f"{mv.artifact_sha256}.v{ZIP_LAYOUT}.zip").write_bytes(model_artifact_bytes(s, mv))
        return self._finished

    def artifact_build(self) -> int:
        """A finished build of the finished campaign's model zip (made in the database)."""
        from alcove.db import open_transaction
        from alcove.models import ArtifactBuild

        cid = self.finished()["campaign_id"]
        with open_transaction() as s:
            row = ArtifactBuild(campaign_id=cid, model_version_ids=[], download_path="/x", status="ready")
            s.add(row)
            s.flush()
            return row.id

    def preview(self) -> int:
        """A finished preview of the owner's (made in the database: the API limits pending previews)."""
        from alcove.db import open_transaction
        from alcove.models import Preview

        with open_transaction() as s:
            row = Preview(
                owner_id=self.owner.id,
                kind="task",
                status="failed",
                error="made by the test",
                spec=small_task_spec(),
                options={"intervals": 4},
            )
            s.add(row)
            s.flush()
            return row.id

    def token(self) -> int:
        return self.post("/me/tokens", {"name": "matrix"})["id"]

    def share(self) -> int:
        return self.post("/shares", {"object_type": "task", "object_id": self.task(), "email": self.third.email})["id"]

    def command_entry(self, admin: Account) -> int:
        r = self.client.post(
            f"{API}/admin/command-oracles",
            json={"name": f"m-{uuid.uuid4().hex[:8]}", "argv": ["/bin/true"]},
            headers=admin.headers,
        )
        assert r.status_code == 201, r.text
        return r.json()["id"]


def csv_upload() -> dict[str, Any]:
    rows = ["simulation,t,q_0,qd_0,fx,fy,fz,mx,my,mz"] + [
        f"{s},{i * 0.01},{0.3 + 0.001 * i},0.1,{i},0,0,0,0.1,0" for s in range(2) for i in range(20)
    ]
    return {"file": ("prelim.csv", io.BytesIO(("\n".join(rows) + "\n").encode()), "text/csv")}


Spec = tuple[str, Callable[[Objects, Account], Call], set[int]]
OK, CREATED, NO_CONTENT = {200}, {201}, {204}

SPECS: dict[str, Spec] = {
    # ---- me, tokens, users, sharing
    "logout": ("any", lambda o, a: Call(fresh_token=True), NO_CONTENT),
    "get_me": ("any", lambda o, a: Call(), OK),
    "update_me": ("any", lambda o, a: Call(json={"display_name": "x"}), OK),
    "list_tokens": ("any", lambda o, a: Call(), OK),
    "create_token": ("any", lambda o, a: Call(json={"name": "n"}), CREATED),
    "revoke_token": ("owned", lambda o, a: Call(path={"token_id": o.token()}), NO_CONTENT),
    "list_users": ("admin", lambda o, a: Call(), OK),
    "create_user": (
        "admin",
        lambda o, a: Call(json={"email": f"u-{uuid.uuid4().hex[:8]}@example.org", "password": "long enough pw"}),
        CREATED,
    ),
    "get_user": ("admin", lambda o, a: Call(path={"user_id": o.third.id}), OK),
    "update_user": ("admin", lambda o, a: Call(path={"user_id": o.third.id}, json={"display_name": "third"}), OK),
    "get_my_job_limits": ("any", lambda o, a: Call(), OK),
    "get_default_job_limits": ("admin", lambda o, a: Call(), OK),
    "update_default_job_limits": ("admin", lambda o, a: Call(json={}), OK),
    "get_user_job_limits": ("admin", lambda o, a: Call(path={"user_id": o.third.id}), OK),
    "update_user_job_limits": ("admin", lambda o, a: Call(path={"user_id": o.third.id}, json={"max_epochs": 5000}), OK),
    "reset_user_job_limits": ("admin", lambda o, a: Call(path={"user_id": o.third.id}), OK),
    "create_share": (
        "owned",
        lambda o, a: Call(json={"object_type": "task", "object_id": o.task(), "email": o.third.email}),
        CREATED,
    ),
    "list_shares": ("owned", lambda o, a: Call(params={"object_type": "task", "object_id": o.task()}), OK),
    "delete_share": ("owned", lambda o, a: Call(path={"share_id": o.share()}), NO_CONTENT),
    # ---- tasks
    "list_tasks": ("any", lambda o, a: Call(), OK),
    "create_task": ("any", lambda o, a: Call(json={"name": "t", "spec": small_task_spec()}), CREATED),
    "list_task_presets": ("any", lambda o, a: Call(), OK),
    "list_model_presets": ("any", lambda o, a: Call(), OK),
    "copy_task_preset": ("any", lambda o, a: Call(path={"key": "head-headrest-2phase"}), CREATED),
    "get_task_schema": ("any", lambda o, a: Call(), OK),
    "check_task": ("any", lambda o, a: Call(json={"spec": small_task_spec()}), OK),
    "get_task": ("owned", lambda o, a: Call(path={"task_id": o.task()}), OK),
    "update_task": ("owned", lambda o, a: Call(path={"task_id": o.task()}, json={"name": "renamed"}), OK),
    "delete_task": ("owned", lambda o, a: Call(path={"task_id": o.task()}), NO_CONTENT),
    "list_task_versions": ("owned", lambda o, a: Call(path={"task_id": o.task()}), OK),
    "get_task_version": ("owned", lambda o, a: Call(path={"task_id": o.task(), "version": 1}), OK),
    "preview_task_scenarios": ("owned", lambda o, a: Call(path={"task_id": o.task()}, json={"n": 2}), OK),
    # ---- oracles
    "list_oracles": ("any", lambda o, a: Call(), OK),
    "create_oracle": ("any", lambda o, a: Call(json={"name": "o", "type": "aux-penalty"}), CREATED),
    "list_oracle_types": ("any", lambda o, a: Call(), OK),
    "get_oracle_params_schema": ("any", lambda o, a: Call(path={"type_name": "aux-penalty"}), OK),
    "list_oracle_presets": ("any", lambda o, a: Call(), OK),
    "copy_oracle_preset": ("any", lambda o, a: Call(path={"key": "aux-penalty"}), CREATED),
    "check_oracle": ("any", lambda o, a: Call(json={"type": "aux-penalty", "params": {}}), OK),
    "get_oracle": ("owned", lambda o, a: Call(path={"oracle_id": o.oracle()}), OK),
    "update_oracle": ("owned", lambda o, a: Call(path={"oracle_id": o.oracle()}, json={"params": {"k": 1e5}}), OK),
    "delete_oracle": ("owned", lambda o, a: Call(path={"oracle_id": o.oracle()}), NO_CONTENT),
    "list_oracle_versions": ("owned", lambda o, a: Call(path={"oracle_id": o.oracle()}), OK),
    "get_oracle_version": ("owned", lambda o, a: Call(path={"oracle_id": o.oracle(), "version": 1}), OK),
    # ---- command catalogue (admin)
    "list_command_oracles": ("admin", lambda o, a: Call(), OK),
    "create_command_oracle": (
        "admin",
        lambda o, a: Call(json={"name": f"e-{uuid.uuid4().hex[:8]}", "argv": ["/bin/true"]}),
        CREATED,
    ),
    "get_command_oracle": ("admin", lambda o, a: Call(path={"entry_id": o.command_entry(a)}), OK),
    "update_command_oracle": (
        "admin",
        lambda o, a: Call(
            path={"entry_id": (i := o.command_entry(a))},
            json={
                "name": o.client.get(f"{API}/admin/command-oracles/{i}", headers=a.headers).json()["name"],
                "argv": ["/bin/false"],
            },
        ),
        OK,
    ),
    "delete_command_oracle": ("admin", lambda o, a: Call(path={"entry_id": o.command_entry(a)}), NO_CONTENT),
    # ---- surrogate configs
    "list_surrogate_configs": ("any", lambda o, a: Call(), OK),
    "create_surrogate_config": ("any", lambda o, a: Call(json={"name": "s", "spec": {"max_epochs": 10}}), CREATED),
    "get_surrogate_config_schema": ("any", lambda o, a: Call(), OK),
    "check_surrogate_config": ("any", lambda o, a: Call(json={"spec": {"patience": 3}}), OK),
    "get_surrogate_config": ("owned", lambda o, a: Call(path={"config_id": o.surrogate()}), OK),
    "update_surrogate_config": (
        "owned",
        lambda o, a: Call(path={"config_id": o.surrogate()}, json={"spec": {"max_epochs": 20}}),
        OK,
    ),
    "delete_surrogate_config": ("owned", lambda o, a: Call(path={"config_id": o.surrogate()}), NO_CONTENT),
    "list_surrogate_config_versions": ("owned", lambda o, a: Call(path={"config_id": o.surrogate()}), OK),
    "get_surrogate_config_version": ("owned", lambda o, a: Call(path={"config_id": o.surrogate(), "version": 1}), OK),
    # ---- campaigns
    "list_campaigns": ("any", lambda o, a: Call(params={"status": "completed"}), OK),
    "create_campaign": (
        "owned_ref",
        lambda o, a: Call(json={"name": "c", "task_id": o.task(), "oracle_id": o.oracle()}),
        CREATED,
    ),
    "check_campaign": (
        "any",
        lambda o, a: Call(json={"name": "c", "task_id": o.task(), "oracle_id": o.oracle()}),
        OK,
    ),
    "get_campaign": ("owned", lambda o, a: Call(path=o.finished()), OK),
    "update_campaign_config": (
        "owned",
        lambda o, a: Call(path={"campaign_id": o.campaign()}, json={"stopping": {"max_iterations": 3}}),
        OK,
    ),
    "start_campaign": ("owned", lambda o, a: Call(path={"campaign_id": o.campaign()}), OK),
    "pause_campaign": ("owned", lambda o, a: Call(path={"campaign_id": o.campaign(start=True)}), OK),
    "resume_campaign": ("owned", lambda o, a: Call(path={"campaign_id": o.paused_campaign()}), OK),
    "cancel_campaign": ("owned", lambda o, a: Call(path={"campaign_id": o.campaign(start=True)}), OK),
    "retry_campaign_step": ("owned", lambda o, a: Call(path={"campaign_id": o.failed_campaign()}), OK),
    "fork_campaign": ("owned", lambda o, a: Call(path=o.finished(), json={"iteration": 1, "name": "fork"}), CREATED),
    "list_campaign_metrics": ("owned", lambda o, a: Call(path=o.finished(), params={"after": 0}), OK),
    "list_campaign_iterations": ("owned", lambda o, a: Call(path=o.finished()), OK),
    "get_iteration_curves": ("owned", lambda o, a: Call(path={**o.finished(), "iteration": 1}), OK),
    "get_iteration_trajectory": ("owned", lambda o, a: Call(path={**o.finished(), "iteration": 1}), OK),
    "get_iteration_candidates": ("owned", lambda o, a: Call(path={**o.finished(), "iteration": 1}), OK),
    "get_candidate_trajectory": ("owned", lambda o, a: Call(path={**o.finished(), "iteration": 1, "slot": 0}), OK),
    "get_pick_curves": ("owned", lambda o, a: Call(path={**o.finished(), "iteration": 1, "pick": 0}), OK),
    "list_campaign_jobs": ("owned", lambda o, a: Call(path=o.finished()), OK),
    "get_campaign_validation": ("owned", lambda o, a: Call(path=o.finished()), OK),
    "list_campaign_events": ("owned", lambda o, a: Call(path=o.finished()), OK),
    "stream_campaign_events": ("owned", lambda o, a: Call(path=o.finished(), params={"timeout": 0}), OK),
    "stream_all_campaign_events": ("any", lambda o, a: Call(params={"timeout": 0}), OK),
    "list_pool_versions": ("owned", lambda o, a: Call(path=o.finished()), OK),
    "download_pool_version": (
        "owned",
        lambda o, a: Call(path={**o.finished(), "version": 1}, params={"format": "csv"}),
        OK,
    ),
    "list_model_versions": ("owned", lambda o, a: Call(path=o.finished()), OK),
    "get_model_artifact": ("owned", lambda o, a: Call(path={**o.finished(), "version": 1}), OK),
    "download_model_artifact": ("owned", lambda o, a: Call(path={**o.finished(), "version": 1}), OK),
    "export_campaign": ("owned", lambda o, a: Call(path=o.finished(), params={"pool_format": "csv"}), OK),
    "get_artifact_build": ("owned", lambda o, a: Call(path={**o.finished(), "build_id": o.artifact_build()}), OK),
    # ---- editor previews (run by workers; here they stay pending)
    "create_task_preview": ("owned", lambda o, a: Call(path={"task_id": o.task()}, json={"intervals": 4}), {202}),
    "create_oracle_preview": ("owned", lambda o, a: Call(path={"oracle_id": o.oracle()}), {202}),
    "get_preview": ("owned", lambda o, a: Call(path={"preview_id": o.preview()}), OK),
    "list_previews": ("any", lambda o, a: Call(), OK),
    # ---- uploads
    "upload_preliminary_dataset": (
        "any",
        lambda o, a: Call(files=csv_upload(), data={"name": "prelim", "chunks": "2"}),
        CREATED,
    ),
    "list_preliminary_datasets": ("any", lambda o, a: Call(), OK),
}


def all_routes(app) -> list:
    from alcove.api.route_table import api_routes

    return [r for r in api_routes(app) if r.path.startswith(API)]


def test_every_route_is_in_the_matrix(app) -> None:
    ops = {r.operation_id for r in all_routes(app)}
    missing = sorted(ops - set(SPECS) - PUBLIC)
    assert not missing, f"routes without an authorization-matrix entry (add them to SPECS): {missing}"
    assert not sorted(set(SPECS) - ops), "SPECS names routes that no longer exist"


def _request(client, route, call: Call, headers: dict[str, str]):
    url = route.path.format(**call.path)
    kwargs: dict[str, Any] = {"headers": headers, "params": call.params}
    if call.files is not None:
        kwargs.update(files=call.files, data=call.data)
    elif call.json is not None:
        kwargs["json"] = call.json
    return client.request(route.method, url, **kwargs)


def _headers(who: Account, call: Call) -> dict[str, str]:
    if call.fresh_token:
        return make_account_token(who)
    return who.headers


def make_account_token(who: Account) -> dict[str, str]:
    from alcove.db import open_transaction
    from alcove.models import ApiToken, TokenKind, User

    with open_transaction() as s:
        token, secret = ApiToken.issue(s.get(User, who.id), kind=TokenKind.personal, name="fresh")
        s.add(token)
    return {"Authorization": f"Bearer {secret}"}


@pytest.fixture(scope="module")
def objects(client, owner: Account) -> Objects:
    return Objects(client, owner, make_account("member", "third"))


ROLES = ("anonymous", "other", "admin", "owner")


@pytest.mark.parametrize("operation_id", sorted(SPECS))
def test_authorization(
    operation_id: str, app, client, objects: Objects, owner: Account, other: Account, admin: Account
) -> None:
    route = next(r for r in all_routes(app) if r.operation_id == operation_id)
    kind, make, ok = SPECS[operation_id]
    results = {}
    for role in ROLES:
        who = {"owner": owner, "other": other, "admin": admin}.get(role)
        call = make(objects, admin)
        r = _request(client, route, call, {} if who is None else _headers(who, call))
        results[role] = (r.status_code, r.text[:300])
    status = {role: code for role, (code, _) in results.items()}
    assert status["anonymous"] == 401, results
    if kind == "any":
        assert status["owner"] in ok and status["other"] in ok and status["admin"] in ok, results
    elif kind == "owned":
        assert status["owner"] in ok, results
        assert status["other"] == 404 and status["admin"] == 404, results
    elif (
        kind == "owned_ref"
    ):  # the owner's objects are referenced in the body: invisible to others, a 422 naming the field
        assert status["owner"] in ok, results
        assert status["other"] == 422 and status["admin"] == 422, results
    elif kind == "admin":
        assert status["owner"] == 403 and status["other"] == 403, results
        assert status["admin"] in ok, results
    else:  # pragma: no cover
        raise AssertionError(kind)
