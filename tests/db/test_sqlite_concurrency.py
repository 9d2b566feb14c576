"""The embedded (SQLite) database under concurrent writers: API requests that read then
write (create/edit definitions, tokens, the token's ``last_used_at`` touch) while a
worker-like thread commits short write transactions the whole time. None may answer 503
"database busy" (or 500): the API's write transactions take the write lock up front
(``BEGIN IMMEDIATE``, waiting up to the busy timeout) instead of failing half way."""

from __future__ import annotations

import threading
import time
import uuid
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

API = "/api/v1"


@pytest.fixture
def sqlite_app(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    from alcove.db import migrate
    from alcove.settings import get_settings

    url = f"sqlite:///{tmp_path / 'alcove.db'}"
    monkeypatch.setenv("ALCOVE_DATABASE_URL", url)
    monkeypatch.setenv("ALCOVE_DATA_DIR", str(tmp_path / "data"))
    monkeypatch.delenv("ALCOVE_BROKER_URL", raising=False)
    get_settings.cache_clear()
    migrate.upgrade(url)
    from alcove.app import create_app

    yield url, create_app(get_settings().model_copy(update={"static_dir": tmp_path}))
    get_settings.cache_clear()


def _account(url: str) -> tuple[int, str]:
    from alcove.db import open_transaction
    from alcove.models import ApiToken, TokenKind, User

    with open_transaction(url) as s:
        user = User(email=f"sq-{uuid.uuid4().hex[:8]}@example.org", role="member")
        s.add(user)
        token, secret = ApiToken.issue(user, kind=TokenKind.personal, name="t")
        s.add(token)
        s.flush()
        return user.id, secret


def test_api_writes_survive_a_concurrent_worker_writer(sqlite_app) -> None:
    from alcove.db import run_transaction
    from alcove.models import WorkerHeartbeat, utcnow

    url, app = sqlite_app
    client = TestClient(app)
    accounts = [_account(url) for _ in range(4)]
    stop = threading.Event()
    writes = [0]

    def worker_writes() -> None:  # what a worker does all the time: short write transactions
        name = f"w-{uuid.uuid4().hex[:6]}"
        run_transaction(lambda s: s.add(WorkerHeartbeat(name=name)), url=url)
        while not stop.is_set():

            def beat(s) -> None:
                row = s.query(WorkerHeartbeat).filter_by(name=name).one()
                row.last_seen_at = utcnow()
                time.sleep(0.002)  # hold the write lock a little, like a real step commit

            run_transaction(beat, url=url)
            writes[0] += 1

    def user_session(account: tuple[int, str]) -> list[int]:
        from alcove.tasks.service import presets

        h = {"Authorization": f"Bearer {account[1]}"}
        spec = presets()[0]["spec"]
        codes = []
        for i in range(6):
            r = client.post(f"{API}/tasks", json={"name": f"t{i}", "spec": spec}, headers=h)
            codes.append(r.status_code)
            if r.status_code == 201:
                codes.append(
                    client.put(f"{API}/tasks/{r.json()['id']}", json={"name": f"renamed {i}"}, headers=h).status_code
                )
            made = client.post(f"{API}/me/tokens", json={"name": f"n{i}"}, headers=h)
            codes.append(made.status_code)
            if made.status_code == 201:  # a first use in a read-only request records last_used_at
                codes.append(
                    client.get(f"{API}/tasks", headers={"Authorization": f"Bearer {made.json()['token']}"}).status_code
                )
        return codes

    writers = [threading.Thread(target=worker_writes) for _ in range(2)]
    for w in writers:
        w.start()
    try:
        with ThreadPoolExecutor(len(accounts)) as pool:
            codes = [c for got in pool.map(user_session, accounts) for c in got]
    finally:
        stop.set()
        for w in writers:
            w.join()
    assert writes[0] > 10, "the worker-like writers did not run concurrently"
    bad = [c for c in codes if c >= 500]
    assert not bad, f"{len(bad)} of {len(codes)} requests failed: {sorted(set(bad))}"
    assert set(codes) <= {200, 201}
    from alcove.db import open_transaction
    from alcove.models import ApiToken

    with open_transaction(url) as s:  # the read-only first uses were recorded
        assert s.query(ApiToken).filter(
            ApiToken.name.like("n%"), ApiToken.last_used_at.is_not(None)
        ).count() == 6 * len(accounts)
