"""Process settings (pydantic-settings), all read from ``ALCOVE_*`` environment variables.

Defaults give the embedded setup: SQLite in ``ALCOVE_DATA_DIR`` and a filesystem broker,
so nothing beyond this package is needed. Production sets ``ALCOVE_DATABASE_URL``
(PostgreSQL) and ``ALCOVE_BROKER_URL`` (Redis).
"""

from __future__ import annotations

import ipaddress
from functools import lru_cache
from pathlib import Path
from typing import Literal

from pydantic import Field, SecretStr, field_validator, model_validator
from pydantic_settings import BaseSettings, SettingsConfigDict

IPNetwork = ipaddress.IPv4Network | ipaddress.IPv6Network


def _split(value: str) -> list[str]:
    return [item.strip() for item in value.split(",") if item.strip()]


class Settings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="ALCOVE_", env_file=".env", extra="ignore")

    data_dir: Path = Field(
        default=Path.home() / ".local" / "share" / "alcove",
        description="Where the embedded database, broker folders and artifacts live",
    )
    database_url: str = Field(default="", description="SQLAlchemy URL; empty means SQLite in data_dir")
    broker_url: str = Field(default="", description="Celery broker URL; empty means the filesystem broker in data_dir")
    admin_email: str = "admin@alcove.local"
    admin_password: SecretStr = Field(
        default=SecretStr("alcove-admin"), description="Password of the first admin, created on first start"
    )
    command_oracles_file: Path | None = Field(
        default=None, description="Server-side YAML catalogue of external (command) oracles"
    )
    api_host: str = "127.0.0.1"
    api_port: int = 8000
    job_lease_seconds: int = 120
    broker_visibility_timeout: int = Field(
        default=6 * 3600, description="Redis redelivers an unacknowledged job after this; must exceed the longest job"
    )
    broker_key_prefix: str = Field(
        default="",
        description="Prefix of every Redis key the broker uses (isolates deployments/tests sharing one Redis)",
    )
    broker_polling_interval: float = Field(
        default=0.1, description="Seconds between polls of the filesystem broker folders"
    )
    worker_heartbeat_seconds: float = Field(
        default=2.0, gt=0, description="How often a worker refreshes its row in worker_heartbeats"
    )
    worker_dead_seconds: float = Field(
        default=10.0,
        gt=0,
        description=(
            "A worker whose heartbeat is older than this is dead: the reconciler gives its running steps to "
            "another worker (keep it several heartbeats long: a slow worker still beats and keeps its step)"
        ),
    )
    reconcile_seconds: float = Field(
        default=2.0, gt=0, description="How often each worker looks for steps of dead workers and lost messages"
    )
    artifact_builds: int = Field(
        default=2,
        ge=1,
        description=(
            "Artifact builds (model zips for downloads, a child process with torch each) running at once across "
            "all workers; more wait for a free slot"
        ),
    )
    outbox_relay_seconds: float = Field(
        default=1.0,
        gt=0,
        description="How often the API and each worker send the jobs still waiting in the outbox (broker back)",
    )
    worker_stale_seconds: float = Field(
        default=60.0, description="A worker not seen for this long counts as gone (readiness, reconciler)"
    )
    worker_watch_seconds: float = Field(
        default=5.0,
        gt=0,
        description=(
            "How often (s) `alcove campaign run --no-worker` checks that a live worker serves the queue "
            "its campaign waits on"
        ),
    )
    worker_concurrency: int | None = Field(
        default=None, description="Processes per worker started by `alcove up` (default: CPU count)"
    )
    static_dir: Path | None = Field(
        default=None, description="Built frontend served at /; default backend/alcove/static"
    )
    trusted_proxies: str = Field(
        default="",
        description=(
            "Comma-separated IP addresses or networks (CIDR) of reverse proxies whose X-Forwarded-For header is "
            "believed; empty: none (the client address is the connection's peer)"
        ),
    )
    health_details_networks: str = Field(
        default="",
        description=(
            "Comma-separated IP addresses or networks (CIDR) of clients that see the details of GET /health/ready "
            "(schema revision, workers, error text) without an admin token; empty: admins only"
        ),
    )
    forwarded_header: Literal["x-forwarded-for", "forwarded"] = Field(
        default="x-forwarded-for",
        description=(
            "The header the trusted proxies write the client address to: X-Forwarded-For, or Forwarded (RFC 7239, "
            "its for= parameters); the other one is never read (a client could have written it)"
        ),
    )
    log_level: str = "INFO"
    access_log: bool = Field(
        default=False, description="Log every HTTP request (uvicorn's access log); always on at log level DEBUG"
    )

    testing: bool = Field(
        default=False, description="A test process: honours test-only hooks such as a fault plan. Never in production."
    )
    fault_plan: Path | None = Field(
        default=None, description="Test-only: JSON file of faults to inject into campaign steps (needs testing=true)"
    )

    @model_validator(mode="after")
    def _refuse_test_hooks_outside_tests(self) -> Settings:
        if self.fault_plan is not None and not self.testing:
            raise ValueError(
                "ALCOVE_FAULT_PLAN: fault injection is only for test processes; "
                "this process is not one (ALCOVE_TESTING is not true): unset ALCOVE_FAULT_PLAN"
            )
        return self

    @model_validator(mode="after")
    def _dead_after_several_beats(self) -> Settings:
        if self.worker_dead_seconds < 2 * self.worker_heartbeat_seconds:
            raise ValueError(
                f"ALCOVE_WORKER_DEAD_SECONDS ({self.worker_dead_seconds:g}) must be at least twice "
                f"ALCOVE_WORKER_HEARTBEAT_SECONDS ({self.worker_heartbeat_seconds:g}): a worker between two beats "
                "would count as dead and lose its step"
            )
        return self

    @field_validator("trusted_proxies", "health_details_networks")
    @classmethod
    def _valid_networks(cls, value: str) -> str:
        for item in _split(value):
            try:
                ipaddress.ip_network(item, strict=False)
            except ValueError:
                raise ValueError(f"{item!r} is not an IP address or network (CIDR)") from None
        return value

    @model_validator(mode="after")
    def _fill_embedded_defaults(self) -> Settings:
        if not self.database_url:
            self.database_url = f"sqlite:///{self.data_dir / 'alcove.db'}"
        if not self.broker_url:
            self.broker_url = "filesystem://localhost/"
        return self

    @property
    def is_embedded_broker(self) -> bool:
        return self.broker_url.startswith("filesystem://")

    @property
    def broker_dir(self) -> Path:
        return self.data_dir / "broker"

    @property
    def artifacts_dir(self) -> Path:
        return self.data_dir / "artifacts"

    @property
    def trusted_proxy_networks(self) -> tuple[IPNetwork, ...]:
        """``trusted_proxies`` parsed (an address is a network of one)."""
        return tuple(ipaddress.ip_network(item, strict=False) for item in _split(self.trusted_proxies))

    @property
    def health_details_network_list(self) -> tuple[IPNetwork, ...]:
        """``health_details_networks`` parsed (an address is a network of one)."""
        return tuple(ipaddress.ip_network(item, strict=False) for item in _split(self.health_details_networks))

    @property
    def is_redis_broker(self) -> bool:
        return self.broker_url.startswith(("redis://", "rediss://"))

    @property
    def is_sqlite(self) -> bool:
        return self.database_url.startswith("sqlite")


@lru_cache
def get_settings() -> Settings:
    return Settings()
