"""The web application: the API routers of every domain, the shared plumbing of
:mod:`alcove.api`, the web UI's static files (the composition root; nothing imports it but
the server)."""

from __future__ import annotations

import logging
import os
from collections.abc import AsyncIterator, Callable
from contextlib import AbstractAsyncContextManager, asynccontextmanager
from pathlib import Path

from fastapi import APIRouter, Depends, FastAPI, Request
from fastapi.responses import HTMLResponse, JSONResponse
from fastapi.routing import APIRoute
from sqlalchemy import exc as sa_exc

import alcove
from alcove.api import health
from alcove.api.errors import COMMON_RESPONSES, BodySizeLimit, install_error_handlers
from alcove.api.input_rules import install_input_rules
from alcove.api.json_numbers import WholeNumbers
from alcove.api.security import SecurityHeaders, install_docs
from alcove.api.static import FrontendMount, SPAStaticFiles
from alcove.api.text_input import install_nul_rule, reject_nul_characters
from alcove.db.retry import is_retryable_db_error
from alcove.settings import Settings, get_settings
from alcove.users import revocation
from alcove.users.ratelimit import make_login_throttle
from alcove.users.service import dummy_password_hash

log = logging.getLogger(__name__)

API_PREFIX = "/api/v1"
DEFAULT_STATIC_DIR = Path(__file__).resolve().parent / "static"


def operation_id(route: APIRoute) -> str:
    """Stable OpenAPI operation ids: the explicit ``operation_id`` or the route function name."""
    return route.operation_id or route.name


def api_routers() -> list[APIRouter]:
    """All ``/api/v1`` routers, each included into the app directly with the prefix (a
    flat route table: FastAPI matches nested routers noticeably slower). The most polled
    routers come first. Add new routers here."""
    from alcove.campaigns.router import router as campaigns_router
    from alcove.campaigns.views.live import router as live_router
    from alcove.campaigns.views.router import router as campaign_views_router
    from alcove.oracles.router import admin_router as command_oracles_router
    from alcove.oracles.router import router as oracles_router
    from alcove.pool.router import router as pool_versions_router
    from alcove.pool.router import uploads as uploads_router
    from alcove.previews.router import router as previews_router
    from alcove.surrogates.router import model_versions as model_versions_router
    from alcove.surrogates.router import router as surrogate_configs_router
    from alcove.tasks.router import router as tasks_router
    from alcove.users.limits_router import router as job_limits_router
    from alcove.users.router import router as users_router

    return [
        campaign_views_router,
        campaigns_router,
        live_router,
        pool_versions_router,
        model_versions_router,
        uploads_router,
        users_router,
        job_limits_router,
        tasks_router,
        oracles_router,
        surrogate_configs_router,
        previews_router,
        command_oracles_router,
    ]


def _lifespan(settings: Settings) -> Callable[[FastAPI], AbstractAsyncContextManager[None]]:
    """While the app serves: the job outbox's relay, which sends the jobs this process (or a
    process that died) recorded while the broker was down, and those a broker restart lost
    (see :mod:`alcove.jobs.outbox`)."""

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        from alcove.jobs.outbox import RelayThread

        relay = RelayThread(settings.outbox_relay_seconds)
        relay.start()
        try:
            yield
        finally:
            relay.stop()

    return lifespan


def create_app(settings: Settings | None = None) -> FastAPI:
    settings = settings or get_settings()
    app = FastAPI(
        lifespan=_lifespan(settings),
        title="alcove",
        version=alcove.__version__,
        description="Active-learning campaigns for data-driven contact surrogates.",
        openapi_url=f"{API_PREFIX}/openapi.json",
        docs_url=None,  # served by install_docs: Swagger UI from this origin, under the same policy
        redoc_url=None,
        generate_unique_id_function=operation_id,
    )
    app.include_router(health.router, prefix=API_PREFIX)
    for router in api_routers():
        app.include_router(
            router, prefix=API_PREFIX, responses=COMMON_RESPONSES, dependencies=[Depends(reject_nul_characters)]
        )
    install_docs(app, f"{API_PREFIX}/docs", f"{API_PREFIX}/openapi.json")
    install_nul_rule(app)
    install_input_rules(app)
    install_error_handlers(app)
    app.add_middleware(WholeNumbers)  # inside the size limit: it reads only bodies the limit let through
    app.add_middleware(BodySizeLimit)
    app.add_middleware(SecurityHeaders)  # outermost of ours: also on errors and the web UI's files

    app.state.trusted_proxies = settings.trusted_proxy_networks
    app.state.forwarded_header = settings.forwarded_header
    app.state.login_throttle = make_login_throttle(settings.broker_url, settings.broker_key_prefix)
    revocation.configure(settings.broker_url, settings.broker_key_prefix)
    dummy_password_hash()  # an unknown e-mail's first login costs what any other does
    _warn_about_retired_settings()

    @app.exception_handler(sa_exc.OperationalError)
    async def _db_busy(request: Request, err: sa_exc.OperationalError) -> JSONResponse:
        # A transaction that lost a race (SQLite "database is locked", PG serialization
        # failure) after the in-process retries: ask the client to retry, never a 500.
        if is_retryable_db_error(err):
            return JSONResponse({"detail": "database busy, retry"}, status_code=503, headers={"Retry-After": "1"})
        log.exception("database error", exc_info=err)
        return JSONResponse({"detail": "database unavailable"}, status_code=503, headers={"Retry-After": "5"})

    _mount_frontend(app, settings.static_dir or DEFAULT_STATIC_DIR)
    return app


#: Settings that no longer do anything, with the reason (a process that still sets one starts
#: and says so once).
RETIRED_SETTINGS = {
    "ALCOVE_SECRET_KEY": "nothing is signed with it: bearer tokens are random values stored as SHA-256 hashes",
}


def _warn_about_retired_settings() -> None:
    for name, why in RETIRED_SETTINGS.items():
        if os.environ.get(name) and name not in _warned:
            _warned.add(name)
            log.warning("%s is set but no longer used (%s); remove it", name, why)


_warned: set[str] = set()


def _mount_frontend(app: FastAPI, static_dir: Path) -> None:
    """Serve the built frontend at ``/`` (after the API routes, so they take precedence)."""
    index = static_dir / "index.html"
    if index.is_file():
        spa = SPAStaticFiles(directory=static_dir, api_prefix=API_PREFIX)
        app.router.routes.append(FrontendMount("/", spa, api_prefix=API_PREFIX, name="frontend"))
        return

    @app.get("/", include_in_schema=False)
    def _no_frontend() -> HTMLResponse:
        return HTMLResponse(
            "<!doctype html><title>alcove</title><h1>alcove</h1>"
            f"<p>The API is at <a href='{API_PREFIX}/docs'>{API_PREFIX}/docs</a>. "
            "The web UI has not been built (see README).</p>"
        )
