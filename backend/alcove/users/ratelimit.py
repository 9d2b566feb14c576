"""Failed-login limit per client address (in addition to the per-account lockout, which
cannot stop one client trying one password on many accounts). In memory, per API process."""

from __future__ import annotations

import threading
import time
from collections import deque


class FailureWindow:
    """At most ``limit`` failures per key in the last ``window_s`` seconds."""

    def __init__(self, limit: int, window_s: float, max_keys: int = 100_000) -> None:
        self.limit = limit
        self.window_s = window_s
        self.max_keys = max_keys
        self._hits: dict[str, deque[float]] = {}
        self._lock = threading.Lock()

    def _recent(self, key: str, now: float) -> deque[float]:
        hits = self._hits.setdefault(key, deque())
        while hits and hits[0] <= now - self.window_s:
            hits.popleft()
        return hits

    def retry_after(self, key: str) -> int:
        """Seconds until ``key`` may try again (0: now)."""
        now = time.monotonic()
        with self._lock:
            hits = self._recent(key, now)
            if len(hits) < self.limit:
                return 0
            return int(hits[0] + self.window_s - now) + 1

    def failed(self, key: str) -> None:
        now = time.monotonic()
        with self._lock:
            if len(self._hits) >= self.max_keys:
                self._hits.clear()
            self._recent(key, now).append(now)


#: 30 failed logins per client address per 5 minutes.
LOGIN_FAILURES = FailureWindow(limit=30, window_s=300.0)
