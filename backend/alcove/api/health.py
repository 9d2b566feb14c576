"""Health (liveness, no dependencies) and readiness (database, broker, workers seen; the
artifacts folder reported beside them).

Readiness answers everyone whether the service is ready (200 or 503, ``{"ready": ...}``);
its details (schema revision, workers and their queues, the artifacts folder, error text: what
helps an attacker too) go only to an admin's bearer token or to a client in ``ALCOVE_HEALTH_DETAILS_NETWORKS``."""

from __future__ import annotations

import time
from typing import Any

import sqlalchemy as sa
from fastapi import APIRouter, Request, Response, status
from pydantic import BaseModel, Field

import alcove
from alcove.api.client_address import client_address, in_networks
from alcove.settings import Settings, get_settings

router = APIRouter(prefix="/health", tags=["health"])


class Health(BaseModel):
    status: str
    version: str


class Check(BaseModel):
    ok: bool
    detail: str = ""
    latency_ms: float | None = None


class ReadinessStatus(BaseModel):
    """What everyone sees."""

    ready: bool


class Readiness(ReadinessStatus):
    """What an admin or a client of ALCOVE_HEALTH_DETAILS_NETWORKS sees."""

    database: Check
    broker: Check
    workers: Check
    workers_seen: int
    queues_served: list[str]
    artifacts: Check = Field(
        description="the artifacts folder (the model zips downloads serve) takes a write, and its free space; "
        "reported only: a full or read-only folder fails the downloads that must build, not readiness"
    )


@router.get("", response_model=Health, summary="Liveness", operation_id="health")
def health() -> Health:
    return Health(status="ok", version=alcove.__version__)


def _timed(fn: Any) -> Check:
    t0 = time.perf_counter()
    try:
        detail = fn() or ""
        return Check(ok=True, detail=detail, latency_ms=round((time.perf_counter() - t0) * 1e3, 2))
    except Exception as err:
        return Check(
            ok=False, detail=f"{type(err).__name__}: {err}"[:300], latency_ms=round((time.perf_counter() - t0) * 1e3, 2)
        )


def check_database() -> str:
    from alcove.db import get_engine, migrate

    with get_engine().connect() as conn:
        conn.execute(sa.text("SELECT 1"))
        from alembic.runtime.migration import MigrationContext

        current = MigrationContext.configure(conn).get_current_revision()
    head = migrate.head_revision()
    if current != head:
        raise RuntimeError(f"schema at revision {current}, code expects {head}: run `alcove db upgrade`")
    return f"revision {current}"


def check_broker(settings: Settings) -> str:
    if settings.is_embedded_broker:
        from alcove.jobs import broker_folders

        folder = broker_folders(settings)["data_folder_out"]
        probe = f"{folder}/.ready-probe"
        with open(probe, "w") as fh:
            fh.write("ok")
        return "filesystem broker"
    from kombu import Connection

    from alcove.jobs import celery_config

    cfg = celery_config(settings)
    with Connection(settings.broker_url, connect_timeout=2, transport_options=cfg["broker_transport_options"]) as conn:
        conn.ensure_connection(max_retries=1, timeout=2)
    return "redis" if settings.broker_url.startswith("redis") else "connected"


def _admin_token(request: Request) -> bool:
    """The request carries a valid bearer token of an active admin (read from the database)."""
    scheme, _, secret = request.headers.get("authorization", "").partition(" ")
    if scheme.lower() != "bearer" or not secret.strip():
        return False
    from alcove.db import get_sessionmaker
    from alcove.models import ApiToken, User, hash_token

    try:
        with get_sessionmaker()() as s:
            row = s.execute(
                sa.select(ApiToken, User)
                .join(User, User.id == ApiToken.user_id)
                .where(ApiToken.token_hash == hash_token(secret.strip()))
            ).first()
    except Exception:  # the database is down: the bare answer (it says not ready)
        return False
    return row is not None and row[0].is_valid() and row[1].is_active and row[1].is_admin


def may_see_details(request: Request, settings: Settings) -> bool:
    client = client_address(request, request.app.state.trusted_proxies, request.app.state.forwarded_header)
    return in_networks(client, settings.health_details_network_list) or _admin_token(request)


@router.get(
    "/ready",
    response_model=Readiness | ReadinessStatus,
    summary="Readiness: database migrated, broker reachable, at least one worker seen",
    operation_id="readiness",
    responses={503: {"model": Readiness | ReadinessStatus}},
)
def readiness(request: Request, response: Response) -> Readiness | ReadinessStatus:
    """200 when ready, else 503. The details (each check, the workers seen and the queues they
    serve, the artifacts folder) only for an admin's bearer token or a client in ALCOVE_HEALTH_DETAILS_NETWORKS;
    anyone else gets `{"ready": ...}` alone."""
    settings = get_settings()
    db = _timed(check_database)
    broker = _timed(lambda: check_broker(settings))
    seen: list[Any] = []

    def workers() -> str:
        from alcove.jobs.heartbeat import live_workers

        seen.extend(live_workers(settings.worker_stale_seconds))
        if not seen:
            raise RuntimeError(f"no worker seen in the last {settings.worker_stale_seconds:.0f} s")
        return f"{len(seen)} worker(s)"

    wk = _timed(workers) if db.ok else Check(ok=False, detail="database unavailable")
    queues = sorted({q for w in seen for q in (w.queues or [])})
    ready = db.ok and broker.ok and wk.ok
    if not ready:
        response.status_code = status.HTTP_503_SERVICE_UNAVAILABLE
    if not may_see_details(request, settings):
        return ReadinessStatus(ready=ready)
    from alcove.api.artifacts_folder import describe

    return Readiness(
        ready=ready,
        database=db,
        broker=broker,
        workers=wk,
        workers_seen=len(seen),
        queues_served=queues,
        artifacts=_timed(describe),
    )
