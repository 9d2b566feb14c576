"""The bound on ids and indices that users pass in (API paths and queries, CLI arguments).

Ids are 32-bit signed integers in the database: a larger value could not name a row, so it
is refused as input instead of overflowing a query. A module of its own (no web or database
import), so the headless CLI checks its arguments without loading FastAPI.
"""

MAX_ID = 2**31 - 1

__all__ = ["MAX_ID"]
