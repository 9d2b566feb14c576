"""Serving the built web UI (backend/alcove/static, written by ``npm run build``).

- Single-page-app fallback: an unknown path outside the API and outside ``assets/`` gets
  ``index.html`` (the client-side router takes over).
- Precompressed files: the build writes ``name.br`` and ``name.gz`` next to every large
  text asset; when the client accepts the encoding, that file is sent with
  ``Content-Encoding`` (no compression work per request).
- Never under the API: a path below the API prefix that no API route serves is the API's own
  404 (no such path) or 405 with ``Allow`` (a path served with other methods), not the web
  UI's (:class:`FrontendMount`).
- Caching: the files in ``assets/`` have a content hash in their name, so they are cached
  for a year as immutable; everything else (``index.html``, which names the current hashes)
  is revalidated on every load (``no-cache``; the ETag makes that a 304).
"""

from __future__ import annotations

import mimetypes
import os
import stat
from pathlib import Path

from starlette.datastructures import Headers
from starlette.exceptions import HTTPException as StarletteHTTPException
from starlette.responses import FileResponse, Response
from starlette.routing import Match, Mount
from starlette.staticfiles import NotModifiedResponse, PathLike, StaticFiles
from starlette.types import Scope

IMMUTABLE = "public, max-age=31536000, immutable"
REVALIDATE = "no-cache"
HASHED_DIR = "assets"
# preferred first: brotli is about 15-20 % smaller than gzip for JavaScript
ENCODINGS = (("br", ".br"), ("gzip", ".gz"))


def accepted_encodings(accept_encoding: str) -> set[str]:
    """Content codings the client accepts (``Accept-Encoding``; ``q=0`` means refused)."""
    accepted: set[str] = set()
    for item in accept_encoding.split(","):
        name, _, params = item.strip().partition(";")
        name = name.strip().lower()
        if not name:
            continue
        q = 1.0
        for param in params.split(";"):
            key, _, value = param.strip().partition("=")
            if key.strip().lower() == "q":
                try:
                    q = float(value)
                except ValueError:
                    q = 0.0
        if q > 0:
            accepted.add(name)
    if "*" in accepted:
        accepted.update(e for e, _ in ENCODINGS)
    return accepted


class SPAStaticFiles(StaticFiles):
    """Static files with a single-page-app fallback, precompressed variants and cache headers."""

    def __init__(self, *, directory: PathLike, api_prefix: str = "/api/v1") -> None:
        super().__init__(directory=directory, html=True)
        self.root = Path(directory).resolve()
        self.api_prefix = api_prefix.strip("/")

    async def get_response(self, path: str, scope: Scope) -> Response:
        try:
            return await super().get_response(path, scope)
        except StarletteHTTPException as err:
            # A missing hashed asset (an old build's name) stays a 404: answering a module
            # request with index.html would only produce a confusing MIME-type error.
            if err.status_code == 404 and not path.startswith((self.api_prefix, HASHED_DIR + "/")):
                return await super().get_response("index.html", scope)
            raise

    def file_response(
        self, full_path: PathLike, stat_result: os.stat_result, scope: Scope, status_code: int = 200
    ) -> Response:
        request_headers = Headers(scope=scope)
        path = Path(full_path)
        try:
            relative = path.resolve().relative_to(self.root)
        except ValueError:
            relative = Path(path.name)
        cache_control = IMMUTABLE if relative.parts[:1] == (HASHED_DIR,) and len(relative.parts) > 1 else REVALIDATE
        headers = {"Cache-Control": cache_control}

        served, served_stat = str(path), stat_result
        variants = [(e, suffix) for e, suffix in ENCODINGS if os.path.isfile(str(path) + suffix)]
        if variants:
            headers["Vary"] = "Accept-Encoding"
            accepted = accepted_encodings(request_headers.get("accept-encoding", ""))
            for encoding, suffix in variants:
                if encoding in accepted:
                    served = str(path) + suffix
                    served_stat = os.stat(served)
                    if not stat.S_ISREG(served_stat.st_mode):
                        served, served_stat = str(path), stat_result
                        continue
                    headers["Content-Encoding"] = encoding
                    break

        media_type = mimetypes.guess_type(path.name)[0] or "application/octet-stream"
        if media_type.startswith("text/") or media_type in (
            "application/javascript",
            "application/json",
            "image/svg+xml",
        ):
            media_type += "; charset=utf-8"
        response = FileResponse(
            served, status_code=status_code, stat_result=served_stat, headers=headers, media_type=media_type
        )
        if self.is_not_modified(response.headers, request_headers):
            return NotModifiedResponse(response.headers)
        return response


class FrontendMount(Mount):
    """The web UI at ``/``, except below the API prefix: there it matches nothing, so a path no
    API route serves gets the router's 404, and a path an API route serves with other methods
    its 405 (a catch-all mount would answer every such request itself: 405 for a method other
    than GET, 404 for a GET)."""

    def __init__(self, path: str, app: StaticFiles, *, api_prefix: str, name: str | None = None) -> None:
        super().__init__(path, app=app, name=name)
        self.api_prefix = api_prefix.rstrip("/")

    def matches(self, scope: Scope) -> tuple[Match, Scope]:
        path = scope.get("path", "")
        if path == self.api_prefix or path.startswith(self.api_prefix + "/"):
            return Match.NONE, {}
        return super().matches(scope)
