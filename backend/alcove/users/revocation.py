"""The revocation generation: a counter shared by every API process, raised after each commit
that revokes a token or changes a user (logout, revoking a token, a new password, an admin's
change of a user). A process trusts a token from its verified-token cache only while the
counter is the one it read before verifying the token, so a revocation at one process is
refused by every other at once.

With Redis as the broker the counter is a Redis key (``<prefix>alcove:auth:generation``,
read once per request, a round trip of well under a millisecond). Without Redis there is no
shared counter and nothing is cached: every request reads its token from the database, which
all processes share. If Redis cannot be reached, the process reads the database too (logged),
until it answers again."""

from __future__ import annotations

import logging
import math
import time
from typing import Protocol

import sqlalchemy as sa
from sqlalchemy.orm import Session

log = logging.getLogger(__name__)


class Generation(Protocol):
    def current(self) -> int | None:
        """The counter, or None when it is not known (then no cached token may be trusted)."""

    def bump(self) -> None:
        """Raise the counter: every process stops trusting its cached tokens."""


class NoGeneration:
    """No shared counter (no Redis): nothing may be cached."""

    def current(self) -> int | None:
        return None

    def bump(self) -> None:
        return None


class RedisGeneration:
    def __init__(self, url: str, key_prefix: str = "") -> None:
        import redis

        self.key = f"{key_prefix}alcove:auth:generation"
        # short timeouts: an unreachable Redis costs a request a database lookup, not seconds
        self.client = redis.Redis.from_url(url, socket_timeout=0.5, socket_connect_timeout=0.5)
        self._warned_at = -math.inf

    def _unavailable(self, err: Exception) -> None:
        now = time.monotonic()
        if now - self._warned_at > 60:
            self._warned_at = now
            log.warning("token revocation: Redis unavailable (%s); tokens are read from the database", err)

    def current(self) -> int | None:
        import redis

        try:
            value = self.client.get(self.key)
        except redis.RedisError as err:
            self._unavailable(err)
            return None
        return int(value) if value is not None else 0

    def bump(self) -> None:
        import redis

        try:
            self.client.incr(self.key)
        except redis.RedisError as err:
            # the revocation is committed; other processes trust a cached copy of the token
            # for at most the cache's time to live
            self._unavailable(err)


_generation: list[Generation] = [NoGeneration()]


def configure(broker_url: str, key_prefix: str = "") -> Generation:
    """Use the counter of this broker in this process (:func:`alcove.app.create_app` calls it)."""
    generation: Generation = (
        RedisGeneration(broker_url, key_prefix) if broker_url.startswith(("redis://", "rediss://")) else NoGeneration()
    )
    _generation[0] = generation
    return generation


def generation() -> Generation:
    return _generation[0]


_KEY = "alcove_bump_generation"


def bump_after_commit(session: Session) -> None:
    """Raise the counter once ``session``'s transaction has committed (never if it rolls
    back): a process that read the counter before the commit then reads the token again."""
    if session.info.get(_KEY):
        return
    session.info[_KEY] = True
    sa.event.listen(session, "after_commit", _bump, once=True)
    sa.event.listen(session, "after_rollback", _forget, once=True)


def _bump(session: Session) -> None:
    session.info.pop(_KEY, None)
    generation().bump()


def _forget(session: Session) -> None:
    session.info.pop(_KEY, None)
