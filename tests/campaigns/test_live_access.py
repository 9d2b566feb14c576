"""Open event streams re-check the token they were opened with and the access it gives: a
revoked token or a removed share ends a campaign's stream (an ``end`` event says why), a
removed share hides that campaign's events from the list stream, a revoked token ends it.

Revocations and unshares are written straight to the database, as another API process
would (the streams must not trust this process's token cache)."""

from __future__ import annotations

from collections.abc import Callable, Iterator

import pytest
import sqlalchemy as sa

from tests.helpers import Account, make_account

from .test_live import add_event, frames

API = "/api/v1"


@pytest.fixture
def running(owner: Account) -> Callable[[], int]:
    """Makes a synthetic campaign of ``owner`` that is still running."""
    from alcove.db import open_transaction
    from alcove.models import Campaign
    from tests.synthetic import synthesize_campaign

    def make() -> int:
        with open_transaction() as s:
            cid = synthesize_campaign(s, owner.id, iterations=1, name="live-access").id
            c = s.get(Campaign, cid)
            c.status, c.finished_at, c.stop_reason = "running", None, None
        return cid

    return make


def share(campaign_id: int, user: Account) -> None:
    from alcove.db import open_transaction
    from alcove.models import Share

    with open_transaction() as s:
        s.add(Share(user_id=user.id, campaign_id=campaign_id, permission="view"))


def unshare(campaign_id: int, user: Account) -> None:
    from alcove.db import open_transaction
    from alcove.models import Share

    with open_transaction() as s:
        s.execute(sa.delete(Share).where(Share.user_id == user.id, Share.campaign_id == campaign_id))


def revoke_all(user: Account) -> None:
    from alcove.db import open_transaction
    from alcove.models import ApiToken, utcnow

    with open_transaction() as s:
        s.execute(sa.update(ApiToken).where(ApiToken.user_id == user.id).values(revoked_at=utcnow()))


def stream(client, path: str, user: Account, timeout: float) -> Iterator[dict]:
    with client.stream("GET", f"{API}{path}", params={"timeout": timeout}, headers=user.headers) as r:
        assert r.status_code == 200, r.read()
        yield from frames(r.iter_lines())


@pytest.mark.parametrize("gone", ["share", "token"])
def test_a_campaign_stream_ends_when_the_share_or_the_token_is_gone(
    client, running: Callable[[], int], gone: str
) -> None:
    """The stream would run 60 s; it ends within the re-check interval with an ``end`` event."""
    cid = running()
    grantee = make_account("member", "grantee")
    share(cid, grantee)
    got: list[dict] = []
    for f in stream(client, f"/campaigns/{cid}/events/stream", grantee, timeout=60):
        got.append(f)
        if f["event"] == "ready":
            unshare(cid, grantee) if gone == "share" else revoke_all(grantee)
    assert [f["event"] for f in got] == ["ready", "end"], got
    assert "campaign" in got[-1]["data"]["reason"] if gone == "share" else "token" in got[-1]["data"]["reason"]


def test_the_list_stream_drops_an_unshared_campaign_and_ends_when_the_token_is_gone(
    client, running: Callable[[], int], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Re-checking before every send (interval 0) makes the order exact: an event committed
    after the unshare is never sent, one committed after the revocation neither."""
    from alcove.campaigns.views import live_access

    monkeypatch.setattr(live_access, "RECHECK_S", 0.0, raising=False)
    grantee = make_account("member", "grantee")
    shared = running()
    share(shared, grantee)
    from alcove.db import open_transaction
    from tests.synthetic import synthesize_campaign

    with open_transaction() as s:  # the grantee's own campaign: its events keep coming
        mine = synthesize_campaign(s, grantee.id, iterations=1, name="own").id
    before = add_event(shared, "step_started")
    marks: dict[str, int] = {}
    got: list[dict] = []
    for f in stream(client, "/campaigns/events/stream", grantee, timeout=60):
        got.append(f)
        if f["event"] == "ready":
            marks["shared_seen"] = add_event(shared, "step_started")
        elif f.get("id") == str(marks.get("shared_seen")):
            unshare(shared, grantee)
            marks["after_unshare"] = add_event(shared, "step_succeeded")
            marks["own"] = add_event(mine, "step_started")
        elif f.get("id") == str(marks.get("own")):
            revoke_all(grantee)
            marks["after_revoke"] = add_event(mine, "step_succeeded")
    sent = [int(f["id"]) for f in got if f["event"] not in ("ready", "end")]
    assert before not in sent  # no resume: only what is committed after connecting
    assert sent == [marks["shared_seen"], marks["own"]], (sent, marks)
    assert got[-1]["event"] == "end" and "token" in got[-1]["data"]["reason"], got[-1]
