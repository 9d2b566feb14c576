"""A request holds at most one connection of the request pool at a time.

A request that holds one connection (its authentication's session, say) and waits for a
second one of the same pool (a cached body's build, a lean read on SQLite) can deadlock the
pool: with 20 concurrent first requests of a dashboard against a pool of 15, every
connection was held by a request waiting for another, and all of them hung until the pool
timed out. Here each route runs cold (no cached token, revision or body) and the pool's
checkouts are counted: the most that are out at once must be 1.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator

import pytest
import sqlalchemy as sa

from tests.helpers import Account, small_task_spec

API = "/api/v1"


@pytest.fixture(scope="module")
def campaign(owner: Account) -> int:
    from alcove.db import open_transaction
    from tests.synthetic import synthesize_campaign

    with open_transaction() as s:
        return synthesize_campaign(
            s, owner.id, iterations=2, name="api-connection-use", curve_samples=11, pool_samples=10, ocp_intervals=10
        ).id


class CheckoutCounter:
    def __init__(self) -> None:
        self.out = self.most = 0
        self._lock = threading.Lock()

    def checkout(self, *_: object) -> None:
        with self._lock:
            self.out += 1
            self.most = max(self.most, self.out)

    def checkin(self, *_: object) -> None:
        with self._lock:
            self.out -= 1


@pytest.fixture
def counter(app) -> Iterator[CheckoutCounter]:
    from alcove.db import get_engine

    engine = get_engine()
    assert engine.dialect.name == "postgresql"
    c = CheckoutCounter()
    sa.event.listen(engine, "checkout", c.checkout)
    sa.event.listen(engine, "checkin", c.checkin)
    yield c
    sa.event.remove(engine, "checkout", c.checkout)
    sa.event.remove(engine, "checkin", c.checkin)


def cold() -> None:
    """Forget every per-process cache a request could be answered from."""
    from alcove.api.caching import RESPONSES
    from alcove.campaigns.views.router import REVISIONS
    from alcove.users.service import TOKENS

    with TOKENS._lock:
        TOKENS._data.clear()
    with RESPONSES._lock:
        RESPONSES._data.clear()
    REVISIONS.clear()


ROUTES = [
    "/campaigns",
    "/campaigns/{cid}",
    "/campaigns/{cid}/metrics",
    "/campaigns/{cid}/metrics?after=1",
    "/campaigns/{cid}/iterations",
    "/campaigns/{cid}/iterations/2/curves",
    "/campaigns/{cid}/iterations/2/trajectory",
    "/campaigns/{cid}/jobs",
    "/campaigns/{cid}/events",
    "/campaigns/{cid}/pool-versions",
    "/campaigns/{cid}/model-versions",
    "/tasks",
    "/oracles",
    "/surrogate-configs",
    "/me",
]


@pytest.mark.parametrize("path", ROUTES)
def test_a_cold_read_holds_one_connection_at_a_time(
    client, owner: Account, campaign: int, counter: CheckoutCounter, path: str
) -> None:
    cold()
    r = client.get(API + path.format(cid=campaign), headers=owner.headers)
    assert r.status_code == 200, r.text
    assert counter.most >= 1  # the counter sees the request's connections
    assert counter.most == 1, f"{path}: {counter.most} connections of the request pool held at once"
    assert counter.out == 0  # and none is left checked out after the answer


def test_a_cold_write_holds_one_connection_at_a_time(client, owner: Account, counter: CheckoutCounter) -> None:
    cold()
    r = client.post(f"{API}/tasks", json={"name": "connection-use", "spec": small_task_spec()}, headers=owner.headers)
    assert r.status_code == 201, r.text
    assert (counter.most, counter.out) == (1, 0)


def test_reading_a_stale_preview_holds_one_connection_at_a_time(
    client, owner: Account, counter: CheckoutCounter
) -> None:
    """The read that marks a stale preview failed writes in its own transaction: the GET's own
    read transaction has ended before it."""
    from datetime import timedelta

    from alcove.db import run_transaction
    from alcove.models import JobOutbox, Preview, utcnow
    from alcove.previews.service import STALE_AFTER

    task = client.post(
        f"{API}/tasks", json={"name": "connection-use-preview", "spec": small_task_spec()}, headers=owner.headers
    ).json()
    preview = client.post(f"{API}/tasks/{task['id']}/previews", headers=owner.headers).json()["id"]
    old = utcnow() - STALE_AFTER - timedelta(seconds=5)
    run_transaction(lambda s: s.execute(sa.update(Preview).where(Preview.id == preview).values(created_at=old)))
    run_transaction(  # its job reached the job queue that long ago and no worker took it
        lambda s: s.execute(sa.update(JobOutbox).where(JobOutbox.subject == f"preview/{preview}").values(sent_at=old))
    )
    cold()
    counter.most = 0
    r = client.get(f"{API}/previews/{preview}", headers=owner.headers)
    assert r.status_code == 200 and r.json()["status"] == "failed", r.text
    assert (counter.most, counter.out) == (1, 0)
