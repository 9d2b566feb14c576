"""Process settings (pydantic-settings), all read from ``ALCOVE_*`` environment variables.

Defaults give the embedded setup: SQLite in ``ALCOVE_DATA_DIR`` and a filesystem broker,
so nothing beyond this package is needed. Production sets ``ALCOVE_DATABASE_URL``
(PostgreSQL) and ``ALCOVE_BROKER_URL`` (Redis).
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

from pydantic import Field, SecretStr, model_validator
from pydantic_settings import BaseSettings, SettingsConfigDict


class Settings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="ALCOVE_", env_file=".env", extra="ignore")

    data_dir: Path = Field(default=Path.home() / ".local" / "share" / "alcove", description="Where the embedded database, broker folders and artifacts live")
    database_url: str = Field(default="", description="SQLAlchemy URL; empty means SQLite in data_dir")
    broker_url: str = Field(default="", description="Celery broker URL; empty means the filesystem broker in data_dir")
    secret_key: SecretStr = Field(default=SecretStr("change-me-in-production"), description="Signs session tokens")
    admin_email: str = "admin@alcove.local"
    admin_password: SecretStr = Field(default=SecretStr("alcove-admin"), description="Password of the first admin, created on first start")
    command_oracles_file: Path | None = Field(default=None, description="Server-side YAML catalogue of external (command) oracles")
    api_host: str = "127.0.0.1"
    api_port: int = 8000
    job_lease_seconds: int = 120
    broker_visibility_timeout: int = 6 * 3600

    @model_validator(mode="after")
    def _fill_embedded_defaults(self) -> "Settings":
        if not self.database_url:
            self.database_url = f"sqlite:///{self.data_dir / 'alcove.db'}"
        if not self.broker_url:
            self.broker_url = "filesystem://"
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


@lru_cache
def get_settings() -> Settings:
    return Settings()
