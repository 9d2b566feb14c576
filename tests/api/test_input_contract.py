"""Inputs and the API contract: a NUL character anywhere in a request's text is a 422 naming
the field (PostgreSQL cannot store it; before, it failed at the database with no field),
an unparseable body is a 422 like any invalid input (before: an undocumented 400), a 405
lists every method the path has in ``Allow`` (before: only the first route's), and query
enums are enforced (``/jobs?status=bogus``: before ``200 []``)."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient

from tests.helpers import Account, small_task_spec

API = "/api/v1"


def nul_error(r, field: str) -> dict:
    assert r.status_code == 422, r.text
    items = [e for e in r.json()["detail"] if e["field"] == field]
    assert items, r.json()
    assert items[0]["type"] == "string_nul" and "NUL character" in items[0]["msg"]
    return items[0]


@pytest.fixture(scope="module")
def campaign_id(client: TestClient, owner: Account) -> int:
    h = owner.headers
    task = client.post(f"{API}/tasks", json={"name": "nul-task", "spec": small_task_spec()}, headers=h).json()
    oracle = client.post(f"{API}/oracles/presets/aux-penalty/copy", headers=h).json()
    body = {"name": "nul-campaign", "task_id": task["id"], "oracle_id": oracle["id"]}
    r = client.post(f"{API}/campaigns", json=body, headers=h)
    assert r.status_code == 201, r.text
    return r.json()["id"]


@pytest.mark.parametrize(
    ("method", "path", "body", "field"),
    [
        ("post", "/tasks/presets/head-headrest-2phase/copy", {"name": "copy\x00"}, "name"),
        ("post", "/me/tokens", {"name": "tok\x00en"}, "name"),
        ("patch", "/me", {"display_name": "\x00"}, "display_name"),
        ("post", "/shares", {"object_type": "task", "object_id": 1, "email": "a\x00@b.org"}, "email"),
        ("post", "/oracles", {"name": "o", "type": "aux-penalty", "params": {"k\x00": 1}}, "params.k\\u0000"),
        ("post", "/oracles", {"name": "o", "type": "aux-penalty", "params": {"r": ["x", "\x00"]}}, "params.r.1"),
    ],
)
def test_a_nul_character_in_a_body_names_the_field(client, owner, method, path, body, field) -> None:
    r = getattr(client, method)(f"{API}{path}", json=body, headers=owner.headers)
    nul_error(r, field)


def test_a_nul_character_in_the_login_email_names_the_field(client) -> None:
    r = client.post(f"{API}/auth/login", json={"email": "x\x00@example.org", "password": "pw"})
    nul_error(r, "email")


def test_a_nul_character_in_a_query_parameter_names_it(client, owner, campaign_id) -> None:
    r = client.get(f"{API}/campaigns/{campaign_id}/jobs?status=%00", headers=owner.headers)
    nul_error(r, "status")
    r = client.get(f"{API}/tasks?search=a%00b", headers=owner.headers)
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == "search"


def test_a_nul_character_in_a_form_field_names_it(client, owner) -> None:
    files = {"file": ("d.csv", b"q_0,qd_0,fx,fy,fz,mx,my,mz\n0,0,0,0,0,0,0,0\n", "text/csv")}
    r = client.post(f"{API}/preliminary-datasets", files=files, data={"name": "up\x00"}, headers=owner.headers)
    nul_error(r, "name")


def test_an_escaped_backslash_u0000_is_ordinary_text(client, owner) -> None:
    r = client.post(f"{API}/me/tokens", json={"name": "literally \\u0000"}, headers=owner.headers)
    assert r.status_code == 201 and r.json()["name"] == "literally \\u0000"


@pytest.mark.parametrize("body", [b"\xaa\x93\xff", b"{not json", b'{"name": '])
def test_an_unparseable_body_is_a_422_with_the_reason(client, owner, body) -> None:
    r = client.post(f"{API}/me/tokens", content=body, headers={**owner.headers, "Content-Type": "application/json"})
    assert r.status_code == 422, r.text
    (item,) = r.json()["detail"]
    assert item["loc"] == ["body"] and item["type"] == "json_invalid" and "request body" in item["msg"]


def test_a_malformed_multipart_upload_is_a_422_with_the_reason(client, owner) -> None:
    """A multipart body whose part header breaks off (Starlette's parser: "Invalid multipart data.", a
    400 the API schema does not list) is invalid input like any other: 422 naming the body."""
    body = b"--XyZ\r\nno colon in this header line\r\n\r\n1,2\r\n--XyZ--\r\n"
    headers = {**owner.headers, "Content-Type": "multipart/form-data; boundary=XyZ"}
    r = client.post(f"{API}/preliminary-datasets", content=body, headers=headers)
    assert r.status_code == 422, r.text
    (item,) = r.json()["detail"]
    assert item["loc"] == ["body"] and item["type"] == "multipart_invalid" and "multipart/form-data" in item["msg"]


@pytest.mark.parametrize(
    ("method", "path", "allow"),
    [
        ("OPTIONS", "/tasks", "GET, POST"),
        ("PATCH", "/tasks/1", "DELETE, GET, PUT"),
        ("PUT", "/tasks/presets", "GET"),  # not /tasks/{task_id}: a task id is a whole number
        ("DELETE", "/oracles/check", "POST"),
        ("DELETE", "/me", "GET, PATCH"),
        ("GET", "/shares/3", "DELETE"),
    ],
)
def test_405_lists_every_method_of_the_path(client, owner, method, path, allow) -> None:
    r = client.request(method, f"{API}{path}", headers=owner.headers)
    assert r.status_code == 405, r.text
    assert r.headers["allow"] == allow


def test_a_negative_id_is_still_the_parameter_s_422(client, owner) -> None:
    r = client.get(f"{API}/tasks/-1", headers=owner.headers)
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == "task_id"


def test_job_status_filter_is_an_enum(client, owner, campaign_id) -> None:
    url = f"{API}/campaigns/{campaign_id}/jobs"
    r = client.get(url, params={"status": "bogus"}, headers=owner.headers)
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == "status.0"
    assert client.get(url, params={"status": ["queued", "running"]}, headers=owner.headers).status_code == 200


def test_downloads_document_their_media_types(app) -> None:
    paths = app.openapi()["paths"]
    export = paths[f"{API}/campaigns/{{campaign_id}}/export"]["get"]["responses"]["200"]["content"]
    assert list(export) == ["application/zip"]
    pool = paths[f"{API}/campaigns/{{campaign_id}}/pool-versions/{{version}}/download"]["get"]["responses"]["200"]
    assert sorted(pool["content"]) == ["application/vnd.apache.parquet", "text/csv"]


def test_a_nul_character_in_a_path_parameter_names_it(client, owner) -> None:
    nul_error(client.post(f"{API}/tasks/presets/a%00b/copy", headers=owner.headers), "key")


def test_a_surrogate_config_takes_the_paper_or_the_gated_architecture(client, owner) -> None:
    h = owner.headers
    r = client.post(f"{API}/surrogate-configs", json={"name": "arch", "spec": {"architecture": "contact"}}, headers=h)
    assert r.status_code == 422, r.text
    err = r.json()["detail"][0]
    assert err["field"] == "spec.architecture" and "'paper' or 'gated'" in err["msg"]
    r = client.post(f"{API}/surrogate-configs", json={"name": "gated", "spec": {"architecture": "gated"}}, headers=h)
    assert r.status_code == 201, r.text
    assert r.json()["spec"]["architecture"] == "gated"
    r = client.post(f"{API}/surrogate-configs", json={"name": "default", "spec": {}}, headers=h)
    assert r.status_code == 201 and r.json()["spec"]["architecture"] == "paper"


def test_the_schema_states_the_nul_rule(client) -> None:
    """Every text a request may carry says it holds no NUL: a string's value, beside a pattern of
    its own, and the names of free-form keys; binary uploads and enumerations are left alone."""
    from alcove.api.text_input import NUL_FREE

    doc = client.get(f"{API}/openapi.json").json()
    schemas = doc["components"]["schemas"]
    assert schemas["TokenCreate"]["properties"]["name"]["allOf"] == [{"pattern": NUL_FREE}]  # beside \S
    assert schemas["LoginIn"]["properties"]["password"]["pattern"] == NUL_FREE
    env = schemas["CommandOracleIn"]["properties"]["env"]
    assert env["propertyNames"] == {"pattern": NUL_FREE} and env["additionalProperties"]["pattern"] == NUL_FREE
    assert schemas["OracleIn"]["properties"]["params"]["propertyNames"] == {"pattern": NUL_FREE}
    assert "pattern" not in schemas["CampaignStatus"]
    upload = doc["paths"][f"{API}/preliminary-datasets"]["post"]["requestBody"]["content"]["multipart/form-data"]
    form = schemas[upload["schema"]["$ref"].rsplit("/", 1)[1]]
    assert "pattern" not in form["properties"]["file"]


def test_a_nul_refusal_names_the_place_without_holding_a_nul(client, owner) -> None:
    body = {"spec": {"a\u0000": {"b": "x\u0000", "c\u0000": 1}}}
    r = client.post(f"{API}/tasks/check", json=body, headers=owner.headers)
    assert r.status_code == 422, r.text
    assert "\u0000" not in r.text.encode().decode("unicode_escape")
    fields = sorted(e["field"] for e in r.json()["detail"])
    assert fields == ["spec.a\\u0000", "spec.a\\u0000.b", "spec.a\\u0000.c\\u0000"]


def test_the_retry_schema_says_iteration_and_step_go_together(client, owner) -> None:
    """What the API refuses (one of the two without the other), the schema refuses too."""
    import jsonschema_rs  # Schemathesis's validator

    rule = {"allOf": client.get(f"{API}/openapi.json").json()["components"]["schemas"]["RetryIn"]["allOf"]}
    validator = jsonschema_rs.Draft202012Validator(rule)
    h = owner.headers
    task = client.post(f"{API}/tasks", json={"name": "retry-rule", "spec": small_task_spec()}, headers=h).json()
    oracle = client.post(f"{API}/oracles/presets/aux-penalty/copy", headers=h).json()
    body = {"name": "retry-rule", "task_id": task["id"], "oracle_id": oracle["id"]}
    cid = client.post(f"{API}/campaigns", json=body, headers=h).json()["id"]
    for body, valid in [
        ({}, True),
        ({"iteration": None, "step": None}, True),
        ({"iteration": 2, "step": "oracle"}, True),
        ({"iteration": 2}, False),
        ({"iteration": 2, "step": None}, False),
        ({"step": "oracle"}, False),
    ]:
        assert validator.is_valid(body) is valid, body
        if not valid:
            r = client.post(f"{API}/campaigns/{cid}/retry", json=body, headers=h)
            assert r.status_code == 422, (body, r.text)
