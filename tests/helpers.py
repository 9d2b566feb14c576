"""Helpers shared by the tests that use the app over HTTP (accounts, task specs, downloads)."""

from __future__ import annotations

import uuid
from dataclasses import dataclass
from pathlib import Path


@dataclass
class Account:
    id: int
    email: str
    password: str
    token: str
    role: str

    @property
    def headers(self) -> dict[str, str]:
        return {"Authorization": f"Bearer {self.token}"}


_HASHES: dict[str, str] = {}


def _password_hash(password: str) -> str:
    """argon2 is slow on purpose: hash the shared test password once per session."""
    from alcove.models import hash_password

    if password not in _HASHES:
        _HASHES[password] = hash_password(password)
    return _HASHES[password]


def make_account(role: str = "member", prefix: str = "user") -> Account:
    from alcove.db import open_transaction
    from alcove.models import ApiToken, TokenKind, User

    email = f"{prefix}-{uuid.uuid4().hex[:8]}@example.org"
    password = "correct horse battery"
    with open_transaction() as s:
        user = User(email=email, display_name=prefix, role=role, password_hash=_password_hash(password))
        s.add(user)
        token, secret = ApiToken.issue(user, kind=TokenKind.personal, name="tests")
        s.add(token)
        s.flush()
        uid = user.id
    return Account(uid, email, password, secret, role)


def unique(prefix: str) -> str:
    return f"{prefix}-{uuid.uuid4().hex[:6]}"


PRESET_TASK = "head-headrest-2phase"


def small_task_spec(intervals: int = 8) -> dict:
    """The paper's task with few intervals (quick OCPs)."""
    from alcove.tasks.service import presets

    spec = next(p for p in presets() if p["key"] == PRESET_TASK)["spec"]
    for ph in spec["phases"]:
        ph["intervals"] = intervals
    return spec


def repo_root() -> Path:
    return Path(__file__).resolve().parents[2]


def download_when_built(client, url: str, headers: dict[str, str], *, params=None, timeout_s: float = 240.0):
    """A download that may answer 202 with an artifact build: poll the build until it is ready,
    then download again (what the web UI and the CLI do)."""
    import time

    r = client.get(url, params=params, headers=headers)
    deadline = time.monotonic() + timeout_s
    while r.status_code == 202:
        location = r.headers["Location"]
        while True:
            build = client.get(location, headers=headers).json()
            assert build["status"] != "failed", build
            if build["status"] == "ready":
                break
            assert time.monotonic() < deadline, f"build not ready in {timeout_s:g} s: {build}"
            time.sleep(0.3)
        r = client.get(url, params=params, headers=headers)
    return r
