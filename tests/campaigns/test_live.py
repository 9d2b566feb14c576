"""The live channel: campaign events as server-sent events, one hub per API process.

The streams run in the real app on PostgreSQL; events are committed by other threads while
a stream is open, as workers commit them."""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable, Iterator

import pytest
import sqlalchemy as sa

from tests.helpers import Account

API = "/api/v1"


@pytest.fixture(scope="module")
def running(owner: Account) -> Callable[[], int]:
    """Makes a synthetic campaign of ``owner`` that is still running."""
    from alcove.db import open_transaction
    from alcove.models import Campaign
    from tests.synthetic import synthesize_campaign

    def make() -> int:
        with open_transaction() as s:
            cid = synthesize_campaign(s, owner.id, iterations=1, name="live").id
            c = s.get(Campaign, cid)
            c.status, c.finished_at, c.stop_reason = "running", None, None
        return cid

    return make


def add_event(campaign_id: int, kind: str = "step_succeeded", **data: object) -> int:
    from alcove.campaigns import repository as repo
    from alcove.db import open_transaction
    from alcove.models import CampaignEvent

    with open_transaction() as s:
        repo.add_event(s, campaign_id, kind, "test", iteration=1, step="evaluate", data=dict(data))
        s.flush()
        return s.scalar(sa.select(sa.func.max(CampaignEvent.id)).where(CampaignEvent.campaign_id == campaign_id))


def finish(campaign_id: int, status: str) -> int:
    """The campaign ends: its row and the status event, in one transaction (as the service does)."""
    from alcove.db import open_transaction
    from alcove.models import Campaign

    with open_transaction() as s:
        s.get(Campaign, campaign_id).status = status
    return add_event(campaign_id, "status", to=status)


def frames(lines: Iterator[str]) -> Iterator[dict]:
    """Parse SSE frames (comments skipped)."""
    frame: dict = {}
    for line in lines:
        if line == "":
            if frame:
                yield frame
            frame = {}
        elif line.startswith(":"):
            continue
        else:
            key, _, value = line.partition(": ")
            frame[key] = json.loads(value) if key == "data" else value


def once_listening(*work: Callable[[], object]) -> threading.Thread:
    """Run ``work`` on a thread as soon as the next stream of this process has subscribed: a
    first connection gets the events committed after it subscribed, so adding them earlier would
    race the request."""
    from alcove.campaigns.views import live

    before = live.subscriptions()

    def run() -> None:
        deadline = time.monotonic() + 30
        while live.subscriptions() <= before and time.monotonic() < deadline:
            time.sleep(0.01)
        for w in work:
            w()

    t = threading.Thread(target=run, daemon=True)
    t.start()
    return t


def test_a_campaign_stream_sends_new_events_as_they_are_committed_and_ends_when_terminal(
    client, owner: Account, running: Callable[[], int]
) -> None:
    cid = running()
    t = once_listening(
        lambda: add_event(cid, "step_started"),
        lambda: add_event(cid, "step_succeeded"),
        lambda: add_event(cid, "status", to="completed"),
    )
    t0 = time.monotonic()
    with client.stream(
        "GET", f"{API}/campaigns/{cid}/events/stream", params={"timeout": 60}, headers=owner.headers
    ) as r:
        assert r.status_code == 200 and r.headers["content-type"].startswith("text/event-stream")
        got = list(frames(r.iter_lines()))
    t.join()
    assert [f["event"] for f in got] == ["ready", "step_started", "step_succeeded", "status"]
    assert got[0]["data"]["complete"] is False  # a first connection: reload what you show
    assert all(f["data"]["campaign_id"] == cid for f in got[1:])
    assert time.monotonic() - t0 < 30  # ended by the terminal status, not by the 60 s timeout


def test_resuming_sends_what_was_missed_then_ready(client, owner: Account, running: Callable[[], int]) -> None:
    cid = running()
    first = add_event(cid)
    second = add_event(cid)
    finish(cid, "cancelled")
    with client.stream(
        "GET", f"{API}/campaigns/{cid}/events/stream", params={"after": first, "timeout": 20}, headers=owner.headers
    ) as r:
        got = list(frames(r.iter_lines()))  # terminal already: backlog, ready, end
    assert [int(f["id"]) for f in got[:2]] == [second, second + 1]
    assert got[-1]["event"] == "ready" and got[-1]["data"]["complete"] is True
    with client.stream(
        "GET",
        f"{API}/campaigns/{cid}/events/stream",
        params={"timeout": 20},
        headers={**owner.headers, "Last-Event-ID": str(second + 1)},
    ) as r:
        assert [f["event"] for f in frames(r.iter_lines())] == ["ready"]


def test_a_resume_with_more_missed_events_than_the_backlog_holds_says_so(
    client, owner: Account, running: Callable[[], int], monkeypatch: pytest.MonkeyPatch
) -> None:
    from alcove.campaigns.views import live

    monkeypatch.setattr(live, "BACKLOG_LIMIT", 2)
    cid = running()
    start = add_event(cid)
    for _ in range(3):
        add_event(cid)
    finish(cid, "failed")
    with client.stream(
        "GET", f"{API}/campaigns/{cid}/events/stream", params={"after": start, "timeout": 20}, headers=owner.headers
    ) as r:
        got = list(frames(r.iter_lines()))
    assert len(got) == 3 and got[-1]["data"] == {"last_event_id": int(got[-1]["id"]), "complete": False}


def test_the_list_stream_sends_events_of_visible_campaigns_only(
    client, owner: Account, other: Account, running: Callable[[], int]
) -> None:
    """Events of the user's own campaigns (also one created after connecting) and of those
    shared with them arrive; another member's campaign's do not."""
    from alcove.db import open_transaction
    from alcove.models import Share

    mine_before = running()
    theirs = running()  # owned by `owner`, not shared with `other`
    shared = running()
    with open_transaction() as s:
        s.add(Share(user_id=other.id, campaign_id=shared, permission="view"))
    made: list[int] = []

    def new_campaign() -> None:
        made.append(running())

    t = once_listening(lambda: add_event(theirs), lambda: add_event(shared), new_campaign)
    seen: list[tuple[str, int]] = []
    with client.stream("GET", f"{API}/campaigns/events/stream", params={"timeout": 4}, headers=other.headers) as r:
        for f in frames(r.iter_lines()):
            if f["event"] != "ready":
                seen.append((f["event"], f["data"]["campaign_id"]))
    t.join()
    assert ("step_succeeded", shared) in seen
    assert not [c for _, c in seen if c in (theirs, mine_before, *made)]
    # the owner's list stream sees the campaign created while it is open
    t = once_listening(new_campaign)
    with client.stream("GET", f"{API}/campaigns/events/stream", params={"timeout": 3}, headers=owner.headers) as r:
        ids = {f["data"]["campaign_id"] for f in frames(r.iter_lines()) if f["event"] != "ready"}
    t.join()
    assert made[-1] in ids


def test_an_event_committed_late_with_a_smaller_id_is_still_delivered(
    client, owner: Account, running: Callable[[], int], pg_url: str
) -> None:
    """Transaction A takes event id n and commits after B has committed n + 1 (two workers
    finishing steps at once): the hub already moved past n, and must still send it."""
    from alcove.db import make_engine
    from alcove.models import CampaignEvent

    cid = running()
    engine = make_engine(pg_url)
    slow = engine.connect()
    slow_tx = slow.begin()

    def insert(conn: sa.Connection) -> None:
        conn.execute(
            sa.insert(CampaignEvent).values(campaign_id=cid, kind="step_failed", message="late", data={}, step="ocp")
        )

    def fast_then_slow() -> None:
        insert(slow)  # takes the smaller id, not committed yet
        add_event(cid, "step_started")  # larger id, committed at once
        time.sleep(2.5)  # the hub polls past it
        slow_tx.commit()
        add_event(cid, "status", to="completed")

    t = once_listening(fast_then_slow)
    with client.stream(
        "GET", f"{API}/campaigns/{cid}/events/stream", params={"timeout": 30}, headers=owner.headers
    ) as r:
        got = [f for f in frames(r.iter_lines()) if f["event"] != "ready"]
    t.join()
    slow.close()
    engine.dispose()
    assert sorted(f["event"] for f in got) == ["status", "step_failed", "step_started"]
    assert got[-1]["event"] == "status" or got[-2]["event"] == "status"


def test_many_viewers_of_one_campaign_cost_one_query_per_poll(app, owner: Account, running: Callable[[], int]) -> None:
    """20 streams on one campaign in one process: the hub reads the events table once per
    poll for all of them, and every stream gets every event."""
    import asyncio

    import httpx

    from alcove.campaigns.views import live

    cid = running()

    async def main() -> tuple[list[list[str]], int, float]:
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://test") as http:

            async def viewer() -> list[str]:
                kinds = []
                async with http.stream(
                    "GET", f"{API}/campaigns/{cid}/events/stream", params={"timeout": 6}, headers=owner.headers
                ) as r:
                    async for line in r.aiter_lines():
                        if line.startswith("event: ") and line != "event: ready":
                            kinds.append(line[7:])
                return kinds

            tasks = [asyncio.create_task(viewer()) for _ in range(20)]
            # a first connection gets the events committed after it subscribed: add them only once
            # all 20 have (the ASGI transport hands over a stream's lines only when it ends)
            hub = live.current_hub()
            deadline = time.monotonic() + 30
            while hub.listeners < 20 and time.monotonic() < deadline:
                await asyncio.sleep(0.02)
            assert hub.listeners == 20, hub.listeners
            polls_before, t0 = hub.polls, time.monotonic()
            await asyncio.to_thread(add_event, cid, "step_started")
            await asyncio.sleep(2.0)
            await asyncio.to_thread(add_event, cid, "status", to="completed")
            results = await asyncio.gather(*tasks)
            return results, hub.polls - polls_before, time.monotonic() - t0

    results, polls, elapsed = asyncio.run(main())
    assert all(kinds == ["step_started", "status"] for kinds in results), results
    # one read per poll interval for all 20 viewers (20 viewers each polling would be 20x)
    assert polls <= elapsed / live.POLL_S + 2, (polls, elapsed)


@pytest.mark.parametrize(
    "value", [b"\xb2", b"\xb9", b"1\xb2", b"-3", b"", b"99999999999999999999999", b"0x10", b" 1 2"]
)
def test_a_malformed_last_event_id_is_ignored_on_both_streams(
    app, owner: Account, running: Callable[[], int], value: bytes
) -> None:
    """Superscript digits (latin-1 0xB2, 0xB9) pass ``str.isdigit`` but not ``int``: any
    value that is not a plain event id is ignored (a first connection: ``complete: false``).
    The raw bytes reach the app through httpx's ASGI transport (the TestClient re-encodes
    header values as UTF-8)."""
    import asyncio

    import httpx

    cid = running()

    async def get(path: str) -> httpx.Response:
        transport = httpx.ASGITransport(app=app)
        async with httpx.AsyncClient(transport=transport, base_url="http://test") as c:
            headers = [*owner.headers.items(), ("Last-Event-ID", value)]
            return await c.get(path, params={"timeout": 0}, headers=headers)

    for path in (f"{API}/campaigns/{cid}/events/stream", f"{API}/campaigns/events/stream"):
        r = asyncio.run(get(path))
        assert r.status_code == 200, (path, value, r.text)
        got = list(frames(iter(r.text.splitlines())))
        assert got[-1]["event"] == "ready" and got[-1]["data"]["complete"] is False, (path, value, got)
