"""Security headers on every answer of the real app (API, web UI files, docs), the docs page
served from this origin, and the retired ALCOVE_SECRET_KEY. The browser side (the pages
work under the policy, no violation reported) is in tests/e2e/test_csp.py."""

from __future__ import annotations

import logging
import re
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from tests.helpers import Account

REQUIRED_DIRECTIVES = {
    "default-src": {"'self'"},
    "connect-src": {"'self'"},
    "img-src": {"'self'", "data:", "blob:"},
    "style-src": {"'self'", "'unsafe-inline'"},
    "frame-ancestors": {"'none'"},
    "base-uri": {"'self'"},
    "form-action": {"'self'"},
    "object-src": {"'none'"},
}


def directives(policy: str) -> dict[str, set[str]]:
    out: dict[str, set[str]] = {}
    for part in policy.split(";"):
        name, *values = part.split()
        out[name] = set(values)
    return out


def assert_secure(r) -> None:
    policy = directives(r.headers["content-security-policy"])
    for name, values in REQUIRED_DIRECTIVES.items():
        assert policy.get(name) == values, (name, policy.get(name))
    # nothing may load from or connect to another host: no host, scheme or wildcard sources
    # beyond the data:/blob: images, and no inline or evaluated scripts
    for name, values in policy.items():
        for value in values:
            assert value in {"'self'", "'none'", "'unsafe-inline'", "data:", "blob:"}, (name, value)
    assert "'unsafe-inline'" not in policy.get("script-src", policy["default-src"])
    assert r.headers["x-content-type-options"] == "nosniff"
    assert r.headers["referrer-policy"] == "no-referrer"
    assert r.headers["x-frame-options"] == "DENY"


def test_every_kind_of_api_answer_has_the_headers(client: TestClient, owner: Account) -> None:
    answers = {
        "health": client.get("/api/v1/health"),
        "authenticated JSON": client.get("/api/v1/me", headers=owner.headers),
        "401": client.get("/api/v1/me"),
        "404": client.get("/api/v1/tasks/999999", headers=owner.headers),
        "422": client.get("/api/v1/tasks/0", headers=owner.headers),
        "login 401": client.post("/api/v1/auth/login", json={"email": "nobody@example.org", "password": "x"}),
        "openapi": client.get("/api/v1/openapi.json"),
        "docs": client.get("/api/v1/docs"),
        "placeholder page": client.get("/"),
    }
    for what, r in answers.items():
        assert r.status_code in (200, 401, 404, 422), (what, r.status_code)
        assert_secure(r)


def test_the_web_ui_files_have_the_headers(tmp_path: Path, api_settings: None) -> None:
    from alcove.app import create_app
    from alcove.settings import get_settings

    (tmp_path / "assets").mkdir()
    (tmp_path / "index.html").write_text('<!doctype html><script type="module" src="/assets/app-1.js"></script>')
    (tmp_path / "assets" / "app-1.js").write_text("console.log(1)")
    app = create_app(get_settings().model_copy(update={"static_dir": tmp_path}))
    with TestClient(app) as c:
        for path in ("/", "/campaigns/3", "/assets/app-1.js", "/assets/missing-2.js"):
            r = c.get(path)
            assert r.status_code in (200, 404), path
            assert_secure(r)
        etag = c.get("/").headers["etag"]
        assert_secure(c.get("/", headers={"If-None-Match": etag}))  # a 304 too


def test_the_docs_page_loads_everything_from_this_origin(client: TestClient) -> None:
    page = client.get("/api/v1/docs")
    assert page.status_code == 200 and page.headers["content-type"].startswith("text/html")
    html = page.text
    scripts = re.findall(r"<script([^>]*)>(.*?)</script>", html, flags=re.S)
    assert scripts and all('src="/' in attrs and not body.strip() for attrs, body in scripts), "an inline script"
    urls = re.findall(r'(?:src|href)="([^"]+)"', html)
    assert urls and all(u.startswith("/api/v1/docs/") for u in urls), urls
    for url in urls:
        r = client.get(url)
        assert r.status_code == 200 and len(r.content) > 0, url
        assert_secure(r)
    assert "SwaggerUIBundle" in client.get("/api/v1/docs/assets/swagger-ui-bundle.js").text
    init = client.get("/api/v1/docs/init.js").text
    assert '"url": "/api/v1/openapi.json"' in init and '"validatorUrl": null' in init


def test_secret_key_is_retired_and_a_process_that_sets_it_warns_once(
    api_settings: None, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture, tmp_path: Path
) -> None:
    """Nothing signs with ALCOVE_SECRET_KEY (bearer tokens are random, stored as SHA-256
    hashes): it is no setting any more; a process that still sets it starts and says so once."""
    from alcove import app as app_module
    from alcove.settings import Settings, get_settings

    assert "secret_key" not in Settings.model_fields
    monkeypatch.setenv("ALCOVE_SECRET_KEY", "left over from an old deployment")
    monkeypatch.setattr(app_module, "_warned", set())
    settings = get_settings().model_copy(update={"static_dir": tmp_path})
    with caplog.at_level(logging.WARNING, logger="alcove.app"):
        for _ in range(2):
            with TestClient(app_module.create_app(settings)) as c:
                assert c.get("/api/v1/health").status_code == 200
    warnings = [r for r in caplog.records if "ALCOVE_SECRET_KEY" in r.getMessage()]
    assert len(warnings) == 1 and "no longer used" in warnings[0].getMessage()
