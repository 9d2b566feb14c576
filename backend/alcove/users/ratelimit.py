"""Login throttling: growing delays per (account, client address) and a failure limit per
client address, shared by every API process through Redis when Redis is the broker, in
process memory (``cachetools``) on the embedded default.

* **Per (account, client)**: the first :attr:`LoginPolicy.free_failures` failures cost
  nothing; after that each further attempt from that client on that account must wait
  ``base_delay_s * 2**(failures - free_failures)`` seconds (1, 2, 4, ... s), at most
  ``max_delay_s``, after the previous one. An attempt made too early is answered 429 with
  ``Retry-After`` and neither checks the password nor counts. A successful login from that
  client clears the pair. The account itself is never locked: its owner on another address
  logs in at once, and on the same address after the current delay.
* **Per client address**: at most ``address_limit`` failures within ``address_window_s`` (a
  fixed window from the first failure), whatever the accounts: one client cannot spray one
  password over many accounts. 429 with ``Retry-After`` (the rest of the window).

The "account" is the e-mail as typed (normalised), whether or not such an account exists:
unknown e-mails are throttled exactly like existing ones, so the answers never tell the two
apart. Keys are hashed (no e-mail is stored in Redis) and expire on their own.

Every attempt is counted as a failure when it starts (atomically with the check), and
refunded when it succeeds: concurrent attempts cannot slip past the limits together.
"""

from __future__ import annotations

import hashlib
import logging
import math
import threading
import time
from dataclasses import dataclass
from typing import Protocol

from cachetools import TLRUCache

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class LoginPolicy:
    #: failures per (account, client) without any delay
    free_failures: int = 5
    #: delay after the first failure beyond the free ones; doubles with each further one ...
    base_delay_s: float = 1.0
    #: ... up to this
    max_delay_s: float = 300.0
    #: a pair's failures are forgotten this long after its last attempt
    pair_memory_s: float = 3600.0
    #: failures per client address ...
    address_limit: int = 30
    #: ... per this window (from the window's first failure)
    address_window_s: float = 300.0

    def delay_after(self, failures: int) -> float:
        """Seconds the next attempt must wait after the ``failures``-th failure in a row."""
        if failures < self.free_failures:
            return 0.0
        return min(self.base_delay_s * 2.0 ** min(failures - self.free_failures, 64), self.max_delay_s)


DEFAULT_POLICY = LoginPolicy()


def account_key(email: str) -> str:
    """The throttling key of an e-mail as typed (case and surrounding blanks ignored)."""
    return hashlib.sha256(email.strip().lower().encode()).hexdigest()[:32]


def _retry_after(wait_s: float) -> int:
    return max(1, math.ceil(wait_s))


class LoginThrottle(Protocol):
    policy: LoginPolicy

    def begin(self, email: str, client: str) -> int:
        """0 when the attempt may go ahead (it is counted as a failure until :meth:`succeeded`),
        else the seconds to wait (``Retry-After``)."""

    def succeeded(self, email: str, client: str) -> None:
        """The attempt begun for ``email`` from ``client`` logged in: clear the pair, refund the address."""

    def clear_account(self, email: str) -> None:
        """Forget the delays of ``email`` on every client (an administrator set a new password)."""


class MemoryLoginThrottle:
    """Per-process state in a ``cachetools.TLRUCache`` (every entry expires on its own)."""

    def __init__(self, policy: LoginPolicy = DEFAULT_POLICY, max_entries: int = 100_000) -> None:
        self.policy = policy
        # ("pair", account, client) -> (failures, next allowed at, expires at)
        # ("addr", client) -> (failures, window ends at, expires at)
        self._state: TLRUCache[tuple[str, ...], tuple[int, float, float]] = TLRUCache(
            maxsize=max_entries, ttu=lambda _key, value, _now: value[2], timer=time.monotonic
        )
        self._lock = threading.Lock()

    def begin(self, email: str, client: str) -> int:
        p = self.policy
        pair, addr = ("pair", account_key(email), client), ("addr", client)
        with self._lock:
            now = time.monotonic()
            failures, next_at, _ = self._state.get(pair, (0, 0.0, 0.0))
            count, window_end, _ = self._state.get(addr, (0, 0.0, 0.0))
            wait = next_at - now
            if count >= p.address_limit:
                wait = max(wait, window_end - now)
            if wait > 0:
                return _retry_after(wait)
            failures += 1
            delay = p.delay_after(failures)
            self._state[pair] = (failures, now + delay, now + max(p.pair_memory_s, delay))
            if window_end <= now:
                count, window_end = 0, now + p.address_window_s
            self._state[addr] = (count + 1, window_end, window_end)
            return 0

    def succeeded(self, email: str, client: str) -> None:
        with self._lock:
            self._state.pop(("pair", account_key(email), client), None)
            addr = ("addr", client)
            hit = self._state.get(addr)
            if hit is not None and hit[0] > 0:
                self._state[addr] = (hit[0] - 1, hit[1], hit[2])

    def clear_account(self, email: str) -> None:
        account = account_key(email)
        with self._lock:
            for key in list(self._state):
                if key[0] == "pair" and key[1] == account:
                    self._state.pop(key, None)


# KEYS: pair, address. ARGV: free failures, base delay ms, max delay ms, pair memory ms,
# address limit, address window ms. Returns 0 (go ahead, counted) or the wait in ms.
# Redis's own clock, so that every API process agrees.
_BEGIN = """
local t = redis.call('TIME')
local now = tonumber(t[1]) * 1000 + math.floor(tonumber(t[2]) / 1000)
local free, base, maxd = tonumber(ARGV[1]), tonumber(ARGV[2]), tonumber(ARGV[3])
local memory, limit, window = tonumber(ARGV[4]), tonumber(ARGV[5]), tonumber(ARGV[6])
local failures = tonumber(redis.call('HGET', KEYS[1], 'n') or '0')
local next_at = tonumber(redis.call('HGET', KEYS[1], 'next') or '0')
local count = tonumber(redis.call('GET', KEYS[2]) or '0')
local wait = next_at - now
if count >= limit then
  local ttl = redis.call('PTTL', KEYS[2])
  if ttl > wait then wait = ttl end
end
if wait > 0 then return wait end
failures = failures + 1
local delay = 0
if failures >= free then delay = math.min(base * 2 ^ math.min(failures - free, 64), maxd) end
redis.call('HSET', KEYS[1], 'n', failures, 'next', now + delay)
redis.call('PEXPIRE', KEYS[1], math.max(memory, delay))
if redis.call('INCR', KEYS[2]) == 1 or redis.call('PTTL', KEYS[2]) < 0 then
  redis.call('PEXPIRE', KEYS[2], window)
end
return 0
"""

# KEYS: pair, address.
_SUCCEEDED = """
redis.call('DEL', KEYS[1])
if tonumber(redis.call('GET', KEYS[2]) or '0') > 0 then redis.call('DECR', KEYS[2]) end
return 0
"""


class RedisLoginThrottle:
    """State in Redis (two small Lua scripts: check-and-count, and refund), shared by every
    API process on that Redis. Keys: ``<prefix>alcove:login:pair:<account hash>:<client>``
    (a hash: failures, next allowed time) and ``<prefix>alcove:login:addr:<client>`` (a
    counter), both expiring. When Redis cannot be reached the process falls back to its
    own memory (logged), so logins keep working and stay throttled per process."""

    def __init__(self, url: str, key_prefix: str = "", policy: LoginPolicy = DEFAULT_POLICY) -> None:
        import redis

        self.policy = policy
        self.prefix = f"{key_prefix}alcove:login:"
        self.client = redis.Redis.from_url(url, socket_timeout=2.0, socket_connect_timeout=2.0)
        self._begin = self.client.register_script(_BEGIN)
        self._succeeded = self.client.register_script(_SUCCEEDED)
        self.fallback = MemoryLoginThrottle(policy)
        self._warned_at = -math.inf

    def _keys(self, email: str, client: str) -> list[str]:
        return [f"{self.prefix}pair:{account_key(email)}:{client}", f"{self.prefix}addr:{client}"]

    def _unavailable(self, err: Exception) -> None:
        now = time.monotonic()
        if now - self._warned_at > 60:
            self._warned_at = now
            log.warning("login throttling: Redis unavailable (%s); limits are per process until it is back", err)

    def begin(self, email: str, client: str) -> int:
        import redis

        p = self.policy
        args = [
            p.free_failures,
            int(p.base_delay_s * 1000),
            int(p.max_delay_s * 1000),
            int(p.pair_memory_s * 1000),
            p.address_limit,
            int(p.address_window_s * 1000),
        ]
        try:
            wait_ms = int(self._begin(keys=self._keys(email, client), args=args))
        except redis.RedisError as err:
            self._unavailable(err)
            return self.fallback.begin(email, client)
        return _retry_after(wait_ms / 1000) if wait_ms > 0 else 0

    def succeeded(self, email: str, client: str) -> None:
        import redis

        self.fallback.succeeded(email, client)
        try:
            self._succeeded(keys=self._keys(email, client))
        except redis.RedisError as err:
            self._unavailable(err)

    def clear_account(self, email: str) -> None:
        import redis

        self.fallback.clear_account(email)
        try:
            keys = list(self.client.scan_iter(match=f"{self.prefix}pair:{account_key(email)}:*", count=1000))
            if keys:
                self.client.delete(*keys)
        except redis.RedisError as err:
            self._unavailable(err)


def make_login_throttle(broker_url: str, key_prefix: str = "", policy: LoginPolicy = DEFAULT_POLICY) -> LoginThrottle:
    """Redis-backed when ``broker_url`` is a Redis URL, else in process memory."""
    if broker_url.startswith(("redis://", "rediss://")):
        return RedisLoginThrottle(broker_url, key_prefix, policy)
    return MemoryLoginThrottle(policy)
