"""Database access: engines, sessions, retry of busy transactions, array blobs, migrations."""

from alcove.db.arrays import decode_arrays, encode_arrays, get_arrays, get_bytes, put_arrays, put_bytes
from alcove.db.engine import is_sqlite, make_engine, normalize_url
from alcove.db.retry import is_retryable_db_error, retry_on_locked, run_transaction_on
from alcove.db.session import (
    dispose_engines,
    get_engine,
    get_sessionmaker,
    get_write_sessionmaker,
    open_transaction,
    run_transaction,
)

__all__ = [
    "decode_arrays",
    "dispose_engines",
    "encode_arrays",
    "get_arrays",
    "get_bytes",
    "get_engine",
    "get_sessionmaker",
    "get_write_sessionmaker",
    "is_retryable_db_error",
    "is_sqlite",
    "make_engine",
    "normalize_url",
    "open_transaction",
    "put_arrays",
    "put_bytes",
    "retry_on_locked",
    "run_transaction",
    "run_transaction_on",
]
