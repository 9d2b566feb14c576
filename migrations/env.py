"""Alembic environment for alcove.

The database URL comes from (first match): ``config.attributes["connection"]`` (an open
connection, used by tests), ``config.attributes["url"]``, ``-x url=...`` on the alembic
command line, then ``alcove.settings`` (``ALCOVE_DATABASE_URL`` / ``ALCOVE_DATA_DIR``).

``render_as_batch=True`` so ALTERs work on SQLite (table copy); SQLite migrations run with
foreign keys off and end with ``PRAGMA foreign_key_check``.
"""

from __future__ import annotations

from logging.config import fileConfig
from typing import Any

import sqlalchemy as sa
from alembic import context
from sqlalchemy.schema import DefaultClause
from sqlalchemy.sql import elements, functions

from alcove.db.engine import is_sqlite, make_engine
from alcove.models import Base, UTCDateTime

config = context.config
if config.config_file_name is not None and config.attributes.get("configure_logger", True):
    fileConfig(config.config_file_name, disable_existing_loggers=False)

target_metadata = Base.metadata


def render_item(type_: str, obj: Any, autogen_context: Any) -> str | bool:
    """Render alcove's types and server defaults portably in migration files.

    * ``UTCDateTime`` -> ``sa.DateTime(timezone=True)``;
    * the JSON/JSONB variant -> ``sa.JSON().with_variant(postgresql.JSONB(), "postgresql")``;
    * server defaults ``now()``, ``true``, ``false`` stay SQL expressions (``sa.func.now()``,
      ``sa.true()``, ``sa.false()``) instead of text frozen in one dialect's spelling.
    """
    if type_ == "type":
        if isinstance(obj, UTCDateTime):
            return "sa.DateTime(timezone=True)"
        if isinstance(obj, sa.JSON):
            if getattr(obj, "_variant_mapping", None):
                autogen_context.imports.add("from sqlalchemy.dialects import postgresql")
                return 'sa.JSON().with_variant(postgresql.JSONB(), "postgresql")'
            return "sa.JSON()"
    if type_ == "server_default" and isinstance(obj, DefaultClause):
        arg = obj.arg
        if isinstance(arg, functions.now):
            return "sa.func.now()"
        if isinstance(arg, elements.True_):
            return "sa.true()"
        if isinstance(arg, elements.False_):
            return "sa.false()"
    return False


def _configure(connection: object) -> None:
    context.configure(
        connection=connection,
        target_metadata=target_metadata,
        render_as_batch=True,
        compare_type=True,
        compare_server_default=False,
        render_item=render_item,
    )


def _url() -> str:
    url = config.attributes.get("url") or context.get_x_argument(as_dictionary=True).get("url")
    if url:
        return url
    from alcove.settings import get_settings

    return get_settings().database_url


def run_migrations_offline() -> None:
    context.configure(
        url=_url(), target_metadata=target_metadata, literal_binds=True, render_as_batch=True, render_item=render_item
    )
    with context.begin_transaction():
        context.run_migrations()


def run_migrations_online() -> None:
    connection = config.attributes.get("connection")
    if connection is not None:
        _configure(connection)
        with context.begin_transaction():
            context.run_migrations()
        return
    url = _url()
    sqlite = is_sqlite(url)
    engine = make_engine(url, foreign_keys=not sqlite)
    try:
        with engine.connect() as conn:
            _configure(conn)
            with context.begin_transaction():
                context.run_migrations()
            if sqlite:
                bad = conn.exec_driver_sql("PRAGMA foreign_key_check").fetchall()
                if bad:
                    raise RuntimeError(f"foreign key violations after migration: {bad[:10]}")
            conn.commit()
    finally:
        engine.dispose()


if context.is_offline_mode():
    run_migrations_offline()
else:
    run_migrations_online()
