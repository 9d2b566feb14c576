"""The campaign fixtures (quick campaigns, PostgreSQL + Redis settings for worker processes)."""

from tests.campaigns.conftest import faults, make_campaign, pg_redis

__all__ = ["faults", "make_campaign", "pg_redis"]
