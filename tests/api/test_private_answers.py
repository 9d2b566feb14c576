"""Answers that carry an account's data are never stored by a browser or a proxy
(``Cache-Control: no-store`` on the login answer and on every JSON answer), and the readiness
check tells everyone whether the service is ready but its details (schema revision, workers,
their queues, error text) only to an admin or to a client in ALCOVE_HEALTH_DETAILS_NETWORKS."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient

from tests.helpers import Account

API = "/api/v1"
DETAILS = {"database", "broker", "workers", "workers_seen", "queues_served"}


def test_the_login_answer_and_authenticated_json_are_not_stored(client, owner: Account) -> None:
    r = client.post(f"{API}/auth/login", json={"email": owner.email, "password": owner.password})
    assert r.status_code == 200 and r.headers["cache-control"] == "no-store"
    for path in ("/me", "/me/tokens", "/campaigns", "/tasks"):
        r = client.get(API + path, headers=owner.headers)
        assert r.status_code == 200 and r.headers["cache-control"] == "no-store", path


def test_the_answers_of_the_response_cache_are_not_stored_either(client, owner: Account) -> None:
    from alcove.db import open_transaction
    from tests.synthetic import synthesize_campaign

    with open_transaction() as s:
        cid = synthesize_campaign(s, owner.id, iterations=1, name="no-store").id
    r = client.get(f"{API}/campaigns/{cid}/metrics", headers=owner.headers)
    assert r.status_code == 200 and "ETag" in r.headers and r.headers["cache-control"] == "no-store"
    again = client.get(f"{API}/campaigns/{cid}/metrics", headers={**owner.headers, "If-None-Match": r.headers["ETag"]})
    assert again.status_code == 304 and again.headers["cache-control"] == "no-store"


def test_readiness_is_bare_for_anyone_and_for_a_member(client, owner: Account) -> None:
    for headers in ({}, owner.headers, {"Authorization": "Bearer alc_not-a-token"}):
        r = client.get(f"{API}/health/ready", headers=headers)
        assert r.status_code in (200, 503)
        assert r.json() == {"ready": r.status_code == 200}, r.json()


def test_readiness_has_its_details_for_an_admin(client, admin: Account) -> None:
    r = client.get(f"{API}/health/ready", headers=admin.headers)
    body = r.json()
    assert set(body) >= DETAILS and body["database"]["detail"].startswith("revision "), body


@pytest.fixture
def details_network(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    from alcove.settings import get_settings

    monkeypatch.setenv("ALCOVE_HEALTH_DETAILS_NETWORKS", "10.1.2.0/24,::1")
    get_settings.cache_clear()
    yield
    monkeypatch.undo()
    get_settings.cache_clear()


def test_readiness_has_its_details_for_a_configured_network_only(app, details_network: None) -> None:
    inside = TestClient(app, client=("10.1.2.3", 40000)).get(f"{API}/health/ready")
    assert set(inside.json()) >= DETAILS, inside.json()
    outside = TestClient(app, client=("10.1.3.3", 40000)).get(f"{API}/health/ready")
    assert set(outside.json()) == {"ready"} and outside.status_code == inside.status_code


def test_a_bad_details_network_is_refused_naming_the_variable(monkeypatch: pytest.MonkeyPatch) -> None:
    from alcove.settings import Settings

    monkeypatch.setenv("ALCOVE_HEALTH_DETAILS_NETWORKS", "10.1.2.0/24,intranet")
    with pytest.raises(ValueError, match="health_details_networks") as err:
        Settings()
    assert "'intranet' is not an IP address or network" in str(err.value)
