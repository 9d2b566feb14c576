"""The running-campaigns limit with real processes (PostgreSQL, Redis, a Celery worker): a
member limited to one running campaign starts two; the second waits, queued, with its reason
in the API's detail and in ``alcove campaign status``, and runs when the first has ended. No job
is lost and none runs twice, though the worker could run both at once."""

from __future__ import annotations

import uuid
from pathlib import Path
from typing import Any

import pytest

from tests.procs import db_rows, run_cli, start_worker
from tests.procs import wait_until as wait_for

pytestmark = [pytest.mark.integration, pytest.mark.slow]


@pytest.fixture
def pg_url(fresh_pg_url: str) -> str:
    """Worker processes: a schema of this test's own."""
    return fresh_pg_url


QUICK_SURROGATE = {"max_epochs": 40, "ensemble_size": 2}


def _member_campaigns(n: int) -> tuple[int, list[int], list[int]]:
    """A member limited to one running campaign, ``n`` quick campaigns of theirs started one
    after the other (each start commits its jobs in the outbox and sends them, as the API does);
    returns the member's id, the campaign ids and the outbox ids sent."""
    from alcove.campaigns import presets, service
    from alcove.campaigns.schemas import CampaignCreate
    from alcove.db import run_transaction
    from alcove.jobs.campaign import send_committed, stage
    from alcove.models import Role, User
    from alcove.users import limits
    from alcove.users.schemas import JobLimitsUpdate

    def member(s: Any) -> int:
        user = User(email=f"fair-{uuid.uuid4().hex[:8]}@example.org", role=Role.member.value)
        s.add(user)
        s.flush()
        limits.set_own(s, user, JobLimitsUpdate(max_running_campaigns=1))
        return user.id

    uid = run_transaction(member)
    ids, sent = [], []
    for i in range(n):

        def create_and_start(s: Any, i: int = i) -> tuple[int, list[int]]:
            data = CampaignCreate(
                name=f"fair {i}",
                task_version_id=presets.task_version_from_preset(s, uid, "head-headrest-2phase", None),
                oracle_version_id=presets.oracle_version_for(s, uid, "aux-penalty"),
                surrogate_config_version_id=presets.surrogate_config_version_for(s, uid, QUICK_SURROGATE),
                seed=i,
                preliminary={"samples": 300, "chunks": 3},
                settings={"ocp_intervals": 20, "replay_dt": 0.01, "validation_motions": 0},
                stopping={"max_iterations": 1},
            )
            c = service.create_campaign(s, uid, data)
            _, jobs = service.start(s, c.id)
            return c.id, stage(s, jobs)

        cid, staged = run_transaction(create_and_start)
        send_committed(staged)
        ids.append(cid)
        sent += staged
    return uid, ids, sent


def test_a_members_second_campaign_waits_for_the_first_and_then_runs_once(
    pg_redis: dict[str, str], pg_url: str, tmp_path: Path
) -> None:
    from alcove.campaigns.views.detail import campaign_out
    from alcove.db import open_transaction
    from alcove.models import Campaign, User

    _, (first, second), sent = _member_campaigns(2)
    assert len(sent) == 1, "only the first campaign's first job is sent"
    with open_transaction() as s:
        c = s.get(Campaign, second)
        assert c is not None
        shown = campaign_out(s, c, s.get(User, c.owner_id))  # what GET /campaigns/{id} answers
    assert shown.campaign.status.value == "queued"
    assert shown.campaign.wait_reason is not None
    assert "1 of your campaigns are running and your limit is 1" in shown.campaign.wait_reason
    status = run_cli(["campaign", "status", str(second)], pg_redis)
    assert status.returncode == 0, status.stderr
    assert "queued" in status.stdout and "waiting for a free place" in status.stdout
    assert db_rows(pg_url, "SELECT status FROM iteration_steps WHERE campaign_id = :c", c=second) == [("pending",)]

    worker = start_worker(pg_redis, tmp_path / "w.log", f"fair-{uuid.uuid4().hex[:4]}", concurrency=2)
    try:
        wait_for(
            lambda: (
                db_rows(
                    pg_url,
                    "SELECT count(*) FROM campaigns WHERE id IN (:a, :b) AND status = 'completed'",
                    a=first,
                    b=second,
                )
                == [(2,)]
            ),
            300,
            "both campaigns to complete",
            worker,
        )
    finally:
        worker.stop()
    # the second ran only after the first had ended
    ((first_done,),) = db_rows(pg_url, "SELECT finished_at FROM campaigns WHERE id = :c", c=first)
    ((second_claimed,),) = db_rows(
        pg_url, "SELECT min(started_at) FROM iteration_steps WHERE campaign_id = :c", c=second
    )
    assert second_claimed >= first_done
    assert db_rows(pg_url, "SELECT wait_reason FROM campaigns WHERE id = :c", c=second) == [(None,)]
    assert db_rows(
        pg_url, "SELECT count(*) FROM campaign_events WHERE campaign_id = :c AND kind = 'admitted'", c=second
    ) == [(1,)]
    # every step of both ran exactly once
    for cid in (first, second):
        steps = db_rows(
            pg_url, "SELECT step, status, attempts FROM iteration_steps WHERE campaign_id = :c ORDER BY id", c=cid
        )
        assert [s for s, _, _ in steps] == ["preliminary", "train", "ocp", "oracle", "evaluate", "append"]
        assert all(status == "succeeded" and attempts == 1 for _, status, attempts in steps), steps
        started = db_rows(
            pg_url,
            "SELECT iteration_index, step, count(*) FROM campaign_events WHERE campaign_id = :c AND kind = "
            "'step_started' GROUP BY iteration_index, step",
            c=cid,
        )
        assert sorted(n for _, _, n in started) == [1] * 6, started
