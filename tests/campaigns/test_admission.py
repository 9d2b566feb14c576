"""The running-campaigns limit without a worker (each backend): a campaign beyond the limit
waits with its steps pending and no job sent; a raised limit or an ended campaign lets the
reconciler admit it exactly once; a waiting campaign that is paused or cancelled stops waiting."""

from __future__ import annotations

import uuid
from typing import Any

from alcove.db import run_transaction


def _member(limit: int | None) -> int:
    from alcove.models import Role, User
    from alcove.users import limits
    from alcove.users.schemas import JobLimitsUpdate

    def work(s: Any) -> int:
        user = User(email=f"adm-{uuid.uuid4().hex[:8]}@example.org", role=Role.member.value)
        s.add(user)
        s.flush()
        limits.set_own(s, user, JobLimitsUpdate(max_running_campaigns=limit))
        return user.id

    return run_transaction(work)


def _started(uid: int, n: int) -> list[tuple[int, list]]:
    from alcove.campaigns import presets, service
    from alcove.campaigns.schemas import CampaignCreate

    out = []
    for i in range(n):

        def work(s: Any, i: int = i) -> tuple[int, list]:
            data = CampaignCreate(
                name=f"adm {i}",
                task_version_id=presets.task_version_from_preset(s, uid, "head-headrest-2phase", None),
                oracle_version_id=presets.oracle_version_for(s, uid, "aux-penalty"),
                surrogate_config_version_id=presets.surrogate_config_version_for(s, uid, {"max_epochs": 5}),
                stopping={"max_iterations": 1},
            )
            c = service.create_campaign(s, uid, data)
            return c.id, service.start(s, c.id)[1]

        out.append(run_transaction(work))
    return out


def _state(cid: int) -> tuple[str, str | None, list[str]]:
    from alcove.campaigns import repository as repo
    from alcove.models import Campaign

    def work(s: Any) -> tuple[str, str | None, list[str]]:
        c = s.get(Campaign, cid)
        return c.status, c.wait_reason, [row.status for _, row in repo.steps_of_campaign(s, cid)]

    return run_transaction(work)


def _reconcile() -> list:
    from alcove.campaigns.run.reconciler import reconcile

    return run_transaction(lambda s: reconcile(s, stale_queued_s=3600))


def test_a_raised_limit_admits_the_waiting_campaign_once(campaign_db: str) -> None:
    from alcove.users import limits
    from alcove.users.schemas import JobLimitsUpdate

    uid = _member(1)
    (_, first_jobs), (second, second_jobs) = _started(uid, 2)
    assert len(first_jobs) == 1 and second_jobs == []
    status, reason, steps = _state(second)
    assert status == "queued" and reason is not None and "your limit is 1" in reason and steps == ["pending"]
    assert [j.campaign_id for j in _reconcile()] == []  # no room: nothing sent, nothing lost

    def raise_limit(s: Any) -> None:
        from alcove.models import User

        limits.set_own(s, s.get(User, uid), JobLimitsUpdate(max_running_campaigns=2))

    run_transaction(raise_limit)
    admitted = _reconcile()
    assert [(j.campaign_id, j.step.value, j.attempt) for j in admitted] == [(second, "preliminary", 1)]
    assert _state(second) == ("queued", None, ["queued"])
    assert _reconcile() == []  # admitted once


def test_an_ended_campaign_frees_its_place(campaign_db: str) -> None:
    from alcove.campaigns import service

    uid = _member(1)
    (first, _), (second, _), (third, _) = _started(uid, 3)
    run_transaction(lambda s: service.cancel(s, first))
    assert _state(first)[0] == "cancelled"
    assert [j.campaign_id for j in _reconcile()] == [second]  # the longest waiting, and only it
    status, reason, _ = _state(third)
    assert status == "queued" and reason is not None


def test_a_waiting_campaign_paused_or_cancelled_stops_waiting(campaign_db: str) -> None:
    from alcove.campaigns import service

    uid = _member(1)
    _, (second, _), (third, _) = _started(uid, 3)
    run_transaction(lambda s: service.pause(s, second))
    assert _state(second)[:2] == ("paused", None)
    run_transaction(lambda s: service.resume(s, second))  # still no room: it waits again
    status, reason, steps = _state(second)
    assert status == "queued" and reason is not None and steps == ["pending"]
    run_transaction(lambda s: service.cancel(s, third))
    assert _state(third) == ("cancelled", None, ["cancelled"])


def test_no_limit_sends_at_once(campaign_db: str) -> None:
    uid = _member(None)
    started = _started(uid, 3)
    assert all(len(jobs) == 1 for _, jobs in started)
    assert all(_state(cid)[1] is None for cid, _ in started)
