"""Schemathesis against a live server, as an outside tester runs it: a real ``alcove serve``
(uvicorn) process on its own migrated PostgreSQL schema, the OpenAPI schema read from it over
HTTP, and Schemathesis's engine with every phase (examples, coverage, fuzzing, and stateful
sequences over the links it infers between operations) and its stock checks: none disabled,
none configured (no 5xx; status codes, content types, headers and bodies as documented;
schema-valid requests accepted and schema-violating ones refused; 405 with a correct ``Allow``
for undeclared methods; deleted resources gone; authentication not ignored). Zero failures.

Bounded by the work, not the clock: a few examples per operation, derandomized by a fixed seed,
so every run sends the same requests through every phase (about 7,400; a time budget would cut the
run where the machine's load puts it, before the stateful phase on a busy machine).
``ALCOVE_TEST_SCHEMATHESIS_TIME`` sets a budget in seconds for a quick local look (0: none).
Run as a member with their own task, oracle and campaign (so ids hit real rows).
A heartbeat row stands in for a worker (readiness answers 200; no job runs: the embedded
broker's folders keep what the fuzzed starts and previews send). Left out: the routes that
would end the run's own authentication (logout, revoking tokens, a password change) and the
SSE streams (long-lived).

One check meets rules the schema does not state: ``positive_data_acceptance`` wants every
schema-valid request accepted, but the operations in ``alcove.api.input_rules``'s
``RULES_BEYOND_THE_SCHEMA`` refuse some with a 422 naming the field and the rule, and their 422
answers in the schema name those rules. OpenAPI 3.1 cannot state most of them: rules
across fields (a range's low end below its high end, one value per joint of the task's model),
ids that must name an object of yours, an uploaded file's CSV content, the user's job limits
(docs/api.md). The NUL rule holds at any depth of a free-form JSON body, and the schema states it
for the body's top-level keys only (a recursive schema, which would state it whole, Schemathesis
cuts off at depth, generating NULs below). A 422 of the check on those operations is reported,
not failed; any other status, any other check and any other operation fails the test.
``use_after_free`` meets the archive: deleting a task, oracle or surrogate config a campaign uses
archives it, so its reads still answer (``archived: true``, docs/api.md); a 200 of those reads
after a DELETE is reported too (:data:`ARCHIVED_ON_DELETE`).
"""

from __future__ import annotations

import os
import time
from collections import defaultdict
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from alcove.api.input_rules import RULES_BEYOND_THE_SCHEMA
from tests.helpers import small_task_spec
from tests.procs import Proc, alcove_env, free_port, http_ok, wait_until

MAX_EXAMPLES = 5
#: another run: ALCOVE_TEST_SCHEMATHESIS_SEED=7; a time budget in seconds: ALCOVE_TEST_SCHEMATHESIS_TIME=30
MAX_TIME_S = float(os.environ.get("ALCOVE_TEST_SCHEMATHESIS_TIME", "0"))
SEED = int(os.environ.get("ALCOVE_TEST_SCHEMATHESIS_SEED", "20"))
#: routes that end the run's own authentication, and the long-lived event streams
EXCLUDED = ["logout", "revoke_token", "update_me", "stream_campaign_events", "stream_all_campaign_events"]
ADMIN_EMAIL, ADMIN_PASSWORD = "admin@schemathesis.test", "schemathesis admin password"
#: reads of the definitions whose DELETE archives a used one instead of removing it
ARCHIVED_ON_DELETE = {
    "get_task",
    "get_task_version",
    "list_task_versions",
    "get_oracle",
    "get_oracle_version",
    "list_oracle_versions",
    "get_surrogate_config",
    "get_surrogate_config_version",
    "list_surrogate_config_versions",
}


@pytest.fixture
def live_server(fresh_pg_url: str, tmp_path: Path) -> Iterator[str]:
    """``alcove serve`` (one uvicorn process) on a migrated schema of this test's own; its base URL."""
    port = free_port()
    env = alcove_env(
        database_url=fresh_pg_url,
        data_dir=str(tmp_path / "data"),
        admin_email=ADMIN_EMAIL,
        admin_password=ADMIN_PASSWORD,
        worker_stale_seconds="3600",
        log_level="WARNING",
    )
    env.pop("ALCOVE_BROKER_URL", None)
    proc = Proc(["serve", "--no-migrate", "--workers", "1", "--port", str(port)], env, tmp_path / "serve.log")
    base = f"http://127.0.0.1:{port}"
    try:
        wait_until(lambda: http_ok(f"{base}/api/v1/health"), 90, "alcove serve", proc)
        yield base
    finally:
        proc.stop()
    log = proc.output()
    assert "Traceback" not in log, log[-4000:]


def _member_token(base: str) -> str:
    """A member with a task, an oracle and a campaign of their own; their personal token."""
    with httpx.Client(base_url=f"{base}/api/v1", timeout=30) as http:
        login = http.post("/auth/login", json={"email": ADMIN_EMAIL, "password": ADMIN_PASSWORD}).json()
        admin = {"Authorization": f"Bearer {login['access_token']}"}
        email, password = "fuzz@schemathesis.test", "fuzz member password"
        made = http.post("/users", json={"email": email, "password": password, "role": "member"}, headers=admin)
        assert made.status_code == 201, made.text
        session = http.post("/auth/login", json={"email": email, "password": password}).json()
        h = {"Authorization": f"Bearer {session['access_token']}"}
        token = http.post("/me/tokens", json={"name": "schemathesis"}, headers=h).json()["token"]
        h = {"Authorization": f"Bearer {token}"}
        task = http.post("/tasks", json={"name": "fuzz", "spec": small_task_spec()}, headers=h).json()
        oracle = http.post("/oracles/presets/aux-penalty/copy", headers=h).json()
        body = {"name": "fuzz", "task_id": task["id"], "oracle_id": oracle["id"]}
        assert http.post("/campaigns", json=body, headers=h).status_code == 201
    return token


def _stand_in_worker(database_url: str) -> None:
    """A heartbeat row, as a worker serving no queue writes it (readiness: 200)."""
    from alcove.db import dispose_engines
    from alcove.jobs.heartbeat import beat
    from alcove.settings import get_settings

    mp = pytest.MonkeyPatch()
    mp.setenv("ALCOVE_DATABASE_URL", database_url)
    get_settings.cache_clear()
    try:
        beat("schemathesis-stand-in@test", queues=[], concurrency=0, starting=True)
    finally:
        dispose_engines(close=True)
        mp.undo()
        get_settings.cache_clear()


def describe(recorder, case_id: str, failure) -> str:
    interaction = recorder.interactions.get(case_id)
    lines = [f"{failure.title}: {failure.message}"]
    if interaction is not None:
        req, resp = interaction.request, interaction.response
        lines.append(f"  {req.method} {req.uri} body={str(req.body)[:300]}")
        if resp is not None:
            lines.append(f"  -> {resp.status_code} {resp.headers} {str(resp.content)[:300]}")
    return "\n".join(lines)


def test_stock_schemathesis_finds_nothing_on_a_live_server(live_server: str, fresh_pg_url: str) -> None:
    import schemathesis
    from schemathesis.config import SchemathesisConfig
    from schemathesis.engine import Status, events, from_schema

    _stand_in_worker(fresh_pg_url)
    token = _member_token(live_server)
    config = SchemathesisConfig.from_dict(
        {
            "seed": SEED,
            "cache": {"enabled": False},  # no state carried from run to run (and no .schemathesis/ folder)
            **({"max-time": MAX_TIME_S} if MAX_TIME_S > 0 else {}),
            "headers": {"Authorization": f"Bearer {token}"},
            "generation": {"max-examples": MAX_EXAMPLES},
        }
    )
    schema = schemathesis.openapi.from_url(f"{live_server}/api/v1/openapi.json", config=config).exclude(
        operation_id=EXCLUDED
    )
    # the stock checks, all of them, with their stock settings
    operation = schema.find_operation_by_id("get_campaign")
    checks = schema.config.checks_config_for(operation=operation)
    assert checks.use_after_free.enabled and checks.positive_data_acceptance.enabled
    failures: dict[tuple[str, str], str] = {}
    reported: dict[str, str] = {}
    errors: list[str] = []
    requests = 0
    operations: set[str] = set()
    phases: dict[str, int] = defaultdict(int)
    started = time.perf_counter()
    for event in from_schema(schema).execute():
        if isinstance(event, (events.ScenarioFinished, events.FuzzScenarioFinished)):
            recorder = event.recorder
            requests += len(recorder.interactions)
            phases[str(getattr(event, "phase", "fuzz"))] += len(recorder.interactions)
            operations.add(recorder.label)
            for case_id, results in recorder.checks.items():
                operation_id = recorder.cases[case_id].value.operation.definition.raw.get("operationId")
                for check in results:
                    if check.status != Status.FAILURE or check.failure_info is None:
                        continue
                    text = describe(recorder, case_id, check.failure_info.failure)
                    status = getattr(check.failure_info.failure, "status_code", None)
                    beyond = check.name == "positive_data_acceptance" and operation_id in RULES_BEYOND_THE_SCHEMA
                    archived = check.name == "use_after_free" and operation_id in ARCHIVED_ON_DELETE
                    if (beyond and status == 422) or archived:
                        reported.setdefault(f"{check.name} on {operation_id}", text)
                    else:
                        failures.setdefault((check.name, recorder.label), text)
        elif isinstance(event, (events.NonFatalError, events.FatalError)):
            errors.append(str(getattr(event, "info", event))[:1500])
    elapsed = time.perf_counter() - started
    print(f"schemathesis: {requests} requests in {elapsed:.1f} s over {len(operations)} operations/scenarios")
    print("requests per phase:", dict(phases))
    print(f"reported (rules beyond the schema, the archive): {sorted(reported)}")
    assert not errors, "\n\n".join(errors)
    assert "Stateful tests" in operations, "the stateful phase did not run (no links inferred?)"
    assert len(operations) >= 60
    assert not failures, f"{len(failures)} failures:\n\n" + "\n\n".join(
        f"{check} on {op}:\n{text}" for (check, op), text in sorted(failures.items())
    )
