"""Schemathesis against the app's OpenAPI schema, as an outside tester runs it: its engine
with every phase (examples, coverage, fuzzing, and stateful sequences over the links it
infers between operations) and every default check (no 5xx; status codes, content types,
headers and bodies as documented; schema-violating requests refused; 405 with a correct
``Allow`` for undeclared methods; deleted resources gone; authentication not ignored).
Zero failures.

Bounded: a few examples per operation and a time budget (``MAX_TIME_S``), derandomized by
a fixed seed. Run as a member with their own task, oracle and campaign (so ids hit real
rows), on a login throttle of its own (the fuzzed logins count against the test client's
address). Left out: routes that would end the run's own authentication (logout, revoking
tokens, a password change), the SSE streams (long-lived), readiness (a documented 503
without a worker) and the model download that builds TorchScript in a child process.

``use_after_free`` is off for reading a task, oracle or surrogate config: deleting one that a
campaign uses archives it (documented in docs/api.md, tested both ways in
``tests/api/test_definitions.py::test_delete_archives_a_used_definition``), so it is still read
afterwards, with ``archived: true``; every other delete stays checked.
``positive_data_acceptance`` also accepts 422 for schema-valid requests: the API answers
422 with the field and the reason for rules OpenAPI cannot state (an id that names nothing
of yours, a cross-field rule, the parameters of a given oracle type, a wrong current
password); that is documented on every operation.
"""

from __future__ import annotations

import os
import time
from collections import defaultdict
from collections.abc import Iterator

import pytest
import schemathesis
from schemathesis.config import SchemathesisConfig
from schemathesis.engine import Status, events, from_schema

from alcove.users.ratelimit import MemoryLoginThrottle

from .helpers import Account, make_account, small_task_spec

MAX_EXAMPLES = 5
#: longer or other runs: ALCOVE_TEST_SCHEMATHESIS_TIME=600 ALCOVE_TEST_SCHEMATHESIS_SEED=7
MAX_TIME_S = float(os.environ.get("ALCOVE_TEST_SCHEMATHESIS_TIME", "60"))
SEED = int(os.environ.get("ALCOVE_TEST_SCHEMATHESIS_SEED", "20"))
EXCLUDED = [
    "readiness",
    "logout",
    "revoke_token",
    "update_me",
    "stream_campaign_events",
    "stream_all_campaign_events",
    "download_model_artifact",
]

#: reads of the definitions whose DELETE archives a used one instead of removing it
ARCHIVED_ON_DELETE = ("get_task", "get_oracle", "get_surrogate_config")


@pytest.fixture(scope="module")
def fuzz_account(client) -> Account:
    who = make_account("member", "fuzz")
    h = who.headers
    task = client.post("/api/v1/tasks", json={"name": "fuzz", "spec": small_task_spec()}, headers=h).json()
    oracle = client.post("/api/v1/oracles/presets/aux-penalty/copy", headers=h).json()
    client.post("/api/v1/campaigns", json={"name": "fuzz", "task_id": task["id"], "oracle_id": oracle["id"]}, headers=h)
    return who


@pytest.fixture
def own_login_throttle(app) -> Iterator[None]:
    previous = app.state.login_throttle
    app.state.login_throttle = MemoryLoginThrottle()
    yield
    app.state.login_throttle = previous


def describe(recorder, case_id: str, failure) -> str:
    interaction = recorder.interactions.get(case_id)
    lines = [f"{failure.title}: {failure.message}"]
    if interaction is not None:
        req, resp = interaction.request, interaction.response
        lines.append(f"  {req.method} {req.uri} body={str(req.body)[:300]}")
        if resp is not None:
            lines.append(f"  -> {resp.status_code} {resp.headers} {str(resp.content)[:300]}")
    return "\n".join(lines)


def test_schemathesis_finds_nothing(app, fuzz_account, own_login_throttle) -> None:
    config = SchemathesisConfig.from_dict(
        {
            "seed": SEED,
            "cache": {"enabled": False},  # no state carried from run to run (and no .schemathesis/ folder)
            "max-time": MAX_TIME_S,
            "headers": {"Authorization": fuzz_account.headers["Authorization"]},
            "generation": {"max-examples": MAX_EXAMPLES},
            "operations": [
                {
                    "include-operation-id": list(ARCHIVED_ON_DELETE),
                    "checks": {"use_after_free": {"enabled": False}},
                }
            ],
            "checks": {
                "positive_data_acceptance": {
                    "expected-statuses": ["2xx", "3xx", "401", "403", "404", "409", "422", "429"]
                }
            },
        }
    )
    schema = schemathesis.openapi.from_asgi("/api/v1/openapi.json", app, config=config).exclude(operation_id=EXCLUDED)
    # the exemption reaches exactly the reads it names
    for operation_id, checked in [
        *((o, False) for o in ARCHIVED_ON_DELETE),
        ("get_campaign", True),
        ("get_user", True),
    ]:
        operation = schema.find_operation_by_id(operation_id)
        assert schema.config.checks_config_for(operation=operation).use_after_free.enabled is checked, operation_id
    failures: dict[tuple[str, str], str] = {}
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
            for case_id, checks in recorder.checks.items():
                for check in checks:
                    if check.status == Status.FAILURE and check.failure_info is not None:
                        key = (check.name, recorder.label)
                        failures.setdefault(key, describe(recorder, case_id, check.failure_info.failure))
        elif isinstance(event, (events.NonFatalError, events.FatalError)):
            errors.append(str(getattr(event, "info", event))[:1500])
    elapsed = time.perf_counter() - started
    print(f"schemathesis: {requests} requests in {elapsed:.1f} s over {len(operations)} operations/scenarios")
    print("requests per phase:", dict(phases))
    assert not errors, "\n\n".join(errors)
    assert "Stateful tests" in operations, "the stateful phase did not run (no links inferred?)"
    assert len(operations) >= 60
    assert not failures, "\n\n".join(f"{check} on {op}:\n{text}" for (check, op), text in sorted(failures.items()))
