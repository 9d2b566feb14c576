"""Serving the built UI (alcove.api.static): precompressed variants by Accept-Encoding,
cache headers (hashed assets immutable, index.html revalidated), SPA fallback. No browser."""

from __future__ import annotations

import gzip
from pathlib import Path

import pytest
from starlette.applications import Starlette
from starlette.testclient import TestClient

from alcove.api.static import IMMUTABLE, SPAStaticFiles, accepted_encodings

APP_JS = "export const answer = 42;\n" * 200


@pytest.fixture
def client(tmp_path: Path) -> TestClient:
    (tmp_path / "assets").mkdir()
    (tmp_path / "index.html").write_text("<!doctype html><title>alcove ui</title>")
    js = tmp_path / "assets" / "app-abc123.js"
    js.write_text(APP_JS)
    (tmp_path / "assets" / "app-abc123.js.gz").write_bytes(gzip.compress(APP_JS.encode()))
    # a stand-in for brotli (the test checks which file is chosen, not the codec)
    (tmp_path / "assets" / "app-abc123.js.br").write_bytes(b"BROTLI-BODY")
    (tmp_path / "assets" / "plain-def456.css").write_text("body{}")
    app = Starlette()
    app.mount("/", SPAStaticFiles(directory=tmp_path, api_prefix="/api/v1"))
    # raw bytes: httpx would decode gzip itself and refuse the fake brotli body
    return TestClient(app)


def _get(client: TestClient, path: str, accept_encoding: str | None) -> tuple[int, dict[str, str], bytes]:
    headers = {"Accept-Encoding": accept_encoding} if accept_encoding is not None else {"Accept-Encoding": "identity"}
    with client.stream("GET", path, headers=headers) as r:
        return r.status_code, dict(r.headers), b"".join(r.iter_raw())


def test_brotli_preferred_then_gzip_then_identity(client: TestClient) -> None:
    status, headers, body = _get(client, "/assets/app-abc123.js", "gzip, deflate, br")
    assert status == 200 and headers["content-encoding"] == "br" and body == b"BROTLI-BODY"
    assert headers["content-type"].startswith("text/javascript") and headers["vary"] == "Accept-Encoding"

    status, headers, body = _get(client, "/assets/app-abc123.js", "gzip")
    assert headers["content-encoding"] == "gzip" and gzip.decompress(body).decode() == APP_JS
    assert int(headers["content-length"]) == len(body) < len(APP_JS)

    status, headers, body = _get(client, "/assets/app-abc123.js", "br;q=0, gzip;q=0")
    assert "content-encoding" not in headers and body.decode() == APP_JS

    status, headers, body = _get(client, "/assets/app-abc123.js", None)
    assert "content-encoding" not in headers and body.decode() == APP_JS


def test_hashed_assets_are_immutable_and_index_is_revalidated(client: TestClient) -> None:
    _, headers, _ = _get(client, "/assets/plain-def456.css", "gzip")
    assert headers["cache-control"] == IMMUTABLE and "content-encoding" not in headers
    for path in ("/", "/index.html", "/campaigns/7"):
        status, headers, body = _get(client, path, "gzip, br")
        assert status == 200 and headers["cache-control"] == "no-cache" and b"alcove ui" in body, path
    # revalidation answers 304 with the ETag
    etag = client.get("/").headers["etag"]
    assert client.get("/", headers={"If-None-Match": etag}).status_code == 304


def test_missing_asset_and_api_paths_are_404_not_the_app(client: TestClient) -> None:
    assert client.get("/assets/app-old999.js").status_code == 404
    assert client.get("/api/v1/nothing").status_code == 404
    assert client.post("/campaigns").status_code == 405


def test_accept_encoding_parsing() -> None:
    assert accepted_encodings("gzip, deflate, br, zstd") >= {"gzip", "br"}
    assert accepted_encodings("br;q=0, gzip;q=0.5") == {"gzip"}
    assert accepted_encodings("*") >= {"br", "gzip"}
    assert accepted_encodings("") == set()
    assert accepted_encodings("gzip;q=bogus") == set()
