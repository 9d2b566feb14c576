"""Security headers on every answer, and the API docs page served from this origin.

Nothing the web UI loads or sends may go to another host, so every response (API, the
built web UI, the docs) carries :data:`CONTENT_SECURITY_POLICY`:

* ``default-src 'self'`` / ``connect-src 'self'``: scripts, fetches (the API, the event
  stream) and everything else only from this origin; no inline or evaluated scripts.
* ``img-src 'self' data: blob:``: plotly.js draws its modebar icons and exports its PNG
  through ``data:`` and ``blob:`` images (the camera button renders the SVG into an image,
  then a canvas); Swagger UI's icons are ``data:`` SVGs.
* ``style-src 'self' 'unsafe-inline'``: plotly.js and Swagger UI set inline styles and
  insert ``<style>`` rules.
* ``object-src 'none'; base-uri 'self'; form-action 'self'; frame-ancestors 'none'``: no
  plugins, no ``<base>`` elsewhere, forms post only here, no framing (clickjacking).

plus ``X-Content-Type-Options: nosniff``, ``Referrer-Policy: no-referrer``,
``X-Frame-Options: DENY`` (for browsers without ``frame-ancestors``) and
``Cross-Origin-Opener-Policy: same-origin``.

Every JSON answer (the login's token, an account's data, errors) carries
``Cache-Control: no-store`` unless it sets its own: no browser or proxy keeps a copy.

FastAPI's docs page loads Swagger UI from a CDN and starts it with an inline script; here
the page is served under the same policy as everything else: Swagger UI's files come from
the ``fastapi-offline`` package (served at ``/api/v1/docs/assets/``) and the start script
is a file of its own (``/api/v1/docs/init.js``).
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

from fastapi import FastAPI, Request
from fastapi.responses import HTMLResponse, Response
from starlette.datastructures import MutableHeaders
from starlette.staticfiles import StaticFiles
from starlette.types import ASGIApp, Message, Receive, Scope, Send

CSP_DIRECTIVES = (
    "default-src 'self'",
    "script-src 'self'",
    "connect-src 'self'",
    "img-src 'self' data: blob:",
    "style-src 'self' 'unsafe-inline'",
    "font-src 'self'",
    "object-src 'none'",
    "base-uri 'self'",
    "form-action 'self'",
    "frame-ancestors 'none'",
)
CONTENT_SECURITY_POLICY = "; ".join(CSP_DIRECTIVES)

SECURITY_HEADERS: tuple[tuple[str, str], ...] = (
    ("content-security-policy", CONTENT_SECURITY_POLICY),
    ("x-content-type-options", "nosniff"),
    ("referrer-policy", "no-referrer"),
    ("x-frame-options", "DENY"),
    ("cross-origin-opener-policy", "same-origin"),
)


class SecurityHeaders:
    """Pure ASGI middleware: adds :data:`SECURITY_HEADERS` to every HTTP response that does
    not set them itself, and ``Cache-Control: no-store`` to a JSON one (no per-request work
    beyond the header list)."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return

        async def send_with_headers(message: Message) -> None:
            if message["type"] == "http.response.start":
                headers = MutableHeaders(scope=message)
                for name, value in SECURITY_HEADERS:
                    if name not in headers:
                        headers.append(name, value)
                if "cache-control" not in headers and headers.get("content-type", "").startswith("application/json"):
                    headers.append("cache-control", "no-store")
            await send(message)

        await self.app(scope, receive, send_with_headers)


def swagger_ui_dir() -> Path:
    """Swagger UI's files as the ``fastapi-offline`` package ships them (without importing it)."""
    spec = importlib.util.find_spec("fastapi_offline")
    if spec is None or not spec.submodule_search_locations:
        raise RuntimeError("the fastapi-offline package (Swagger UI's files) is not installed")
    return Path(next(iter(spec.submodule_search_locations))) / "static"


_DOCS_HTML = """<!doctype html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>{title}</title>
<link rel="icon" type="image/png" href="{assets}/favicon.png">
<link rel="stylesheet" href="{assets}/swagger-ui.css">
</head>
<body>
<div id="swagger-ui"></div>
<script src="{assets}/swagger-ui-bundle.js"></script>
<script src="{init}"></script>
</body>
</html>
"""

_DOCS_INIT = """window.ui = SwaggerUIBundle(Object.assign({config}, {{
  presets: [SwaggerUIBundle.presets.apis, SwaggerUIBundle.SwaggerUIStandalonePreset],
}}));
"""


def install_docs(app: FastAPI, docs_url: str, openapi_url: str) -> None:
    """Serve Swagger UI at ``docs_url`` from this origin (create the app with ``docs_url=None``)."""
    assets = f"{docs_url}/assets"
    app.mount(assets, StaticFiles(directory=swagger_ui_dir()), name="swagger-ui-assets")

    # plain Starlette routes, as FastAPI registers its own docs page: public, outside the API schema
    async def swagger_ui(request: Request) -> HTMLResponse:
        root = request.scope.get("root_path", "")
        title = f"{app.title} - API docs"
        return HTMLResponse(_DOCS_HTML.format(title=title, assets=root + assets, init=f"{root}{docs_url}/init.js"))

    async def swagger_ui_init(request: Request) -> Response:
        config = {
            "url": request.scope.get("root_path", "") + openapi_url,
            "dom_id": "#swagger-ui",
            "layout": "BaseLayout",
            "deepLinking": True,
            "showExtensions": True,
            "showCommonExtensions": True,
            "persistAuthorization": False,
            "validatorUrl": None,  # the default badge would load an image from validator.swagger.io
        }
        return Response(_DOCS_INIT.format(config=json.dumps(config)), media_type="text/javascript; charset=utf-8")

    app.add_route(docs_url, swagger_ui, include_in_schema=False)
    app.add_route(f"{docs_url}/init.js", swagger_ui_init, include_in_schema=False)
