"""An integer-valued JSON number is an integer, as JSON Schema reads ``"type": "integer"``
(``2.0``, ``1e3``); a fraction, a numeric string or a boolean is still refused."""

from __future__ import annotations

import pytest

from alcove.api.json_numbers import whole_numbers

API = "/api/v1"


def test_whole_numbers_rewrites_only_integer_valued_numbers() -> None:
    got = whole_numbers(b'{"a": 2.0, "b": 1e3, "c": 2.5, "d": "1.0", "e": [-0.0, 1e300], "f": "\\u0000"}')
    assert got == b'{"a":2,"b":1000,"c":2.5,"d":"1.0","e":[0,1e+300],"f":"\\u0000"}'
    assert whole_numbers(b'{"a": 2}') == b'{"a": 2}'  # nothing to rewrite: the same bytes
    assert whole_numbers(b"{not json 1.0") == b"{not json 1.0"  # the route says what is wrong with it


@pytest.mark.parametrize(
    ("days", "status"), [(30, 201), (30.0, 201), (3e1, 201), (30.5, 422), ("30", 422), (True, 422)]
)
def test_an_integer_field_takes_an_integer_valued_number(client, owner, days, status) -> None:
    r = client.post(f"{API}/me/tokens", json={"name": "numbers", "expires_in_days": days}, headers=owner.headers)
    assert r.status_code == status, r.text
    if status == 201:
        assert r.json()["expires_at"] is not None


def test_a_nested_integer_and_a_float_field_alike(client, owner) -> None:
    spec = {"max_epochs": 200.0, "ensemble_size": 2.0, "learning_rate": 1.0}
    r = client.post(f"{API}/surrogate-configs", json={"name": "numbers", "spec": spec}, headers=owner.headers)
    assert r.status_code == 201, r.text
    assert r.json()["spec"]["max_epochs"] == 200 and r.json()["spec"]["learning_rate"] == 1.0
