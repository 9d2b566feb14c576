"""Artifact builds, the API side: a download whose model artifact zips are not stored yet
(``.../artifact.zip``, a campaign's ``export`` with models) is answered 202 with a build
instead of building in the request. :func:`stored_or_build` checks first that the artifacts
folder can take the zips (a full or read-only folder is answered 507 or 503 at once), then
finds the build already under way for the same download or records a new one with its job in
the job outbox, in its own short write transaction; the route sends the job after that commit
(:func:`send`). The worker side is :mod:`alcove.surrogates.artifact_build_worker`."""

from __future__ import annotations

from collections.abc import Sequence
from datetime import UTC, timedelta
from pathlib import Path
from typing import Any

import sqlalchemy as sa
from sqlalchemy.orm import Session

from alcove.api.artifacts_folder import require_writable
from alcove.errors import NotFound
from alcove.jobs import outbox
from alcove.jobs.heartbeat import dead_worker_reason
from alcove.models import ArtifactBuild, ArtifactBuildStatus, Campaign, ModelVersion, User, utcnow
from alcove.settings import get_settings
from alcove.surrogates.artifact_zips import BUILD_TIMEOUT_S, missing_zips, zip_path, zips_dir
from alcove.surrogates.schemas import ArtifactBuildRead
from alcove.users.access import get_for

#: The job (queue ``artifacts``); its message is the build's id.
ARTIFACT_BUILD_JOB = "alcove.artifacts.build"
QUEUE = "artifacts"
#: A queued build no worker touched for this long (none took its job, or none listens on the
#: queue) is failed with the reason when read; a build waiting for a free slot is touched by its
#: job every few seconds, so it is not stale.
STALE_AFTER = timedelta(minutes=5)
#: Finished builds older than this are deleted when a new one is recorded.
KEEP_FINISHED = timedelta(days=7)
ACTIVE = (ArtifactBuildStatus.queued.value, ArtifactBuildStatus.running.value)


def subject(build_id: int) -> str:
    """The outbox subject of a build's job."""
    return f"artifact-build/{build_id}"


def stored_or_build(
    session: Session, user: User, campaign_id: int, versions: Sequence[ModelVersion], download_path: str
) -> dict[int, Path] | ArtifactBuild:
    """The stored zips of ``versions`` (id -> path), or the build that makes the missing ones
    (recorded and committed, its job in the outbox: call :func:`send` with its id)."""
    missing = missing_zips(versions)
    if not missing:
        return {mv.id: zip_path(mv) for mv in versions}
    require_writable(zips_dir(), "cannot build the model artifact zips")
    ids = sorted(mv.id for mv in missing)
    # end the read transaction first: the request never holds two connections of the pool at once
    if session.in_transaction() and not session.new and not session.dirty and not session.deleted:
        session.commit()
    from alcove.db import run_transaction

    build_id = run_transaction(lambda s: _find_or_record(s, user.id, campaign_id, ids, download_path))
    return get(session, user, campaign_id, build_id)


def _find_or_record(s: Session, user_id: int, campaign_id: int, ids: list[int], download_path: str) -> int:
    under_way = s.scalars(
        sa.select(ArtifactBuild)
        .where(
            ArtifactBuild.campaign_id == campaign_id,
            ArtifactBuild.download_path == download_path,
            ArtifactBuild.status.in_(ACTIVE),
        )
        .order_by(ArtifactBuild.id.desc())
    ).first()
    # the build under way covers what is missing now (while it runs, the zips it stored are not)
    if under_way is not None and set(ids) <= set(under_way.model_version_ids) and stale_reason(s, under_way) is None:
        return under_way.id
    s.execute(
        sa.delete(ArtifactBuild).where(
            ArtifactBuild.campaign_id == campaign_id,
            ArtifactBuild.status.not_in(ACTIVE),
            ArtifactBuild.created_at < utcnow() - KEEP_FINISHED,
        )
    )
    row = ArtifactBuild(
        campaign_id=campaign_id,
        requested_by_id=user_id,
        model_version_ids=ids,
        download_path=download_path,
        models_total=len(ids),
    )
    s.add(row)
    s.flush()
    outbox.record(s, ARTIFACT_BUILD_JOB, (row.id,), subject=subject(row.id))
    return row.id


def send(build_id: int) -> None:
    """After the commit: send the build's job now. A failed send loses nothing: the job waits
    in the outbox and the relay sends it when the broker is back."""
    from alcove.db import open_transaction

    with open_transaction() as s:
        ids = outbox.unsent_ids(s, subject(build_id))
    outbox.send_now(ids)


def get(session: Session, user: User, campaign_id: int, build_id: int) -> ArtifactBuild:
    """Build ``build_id`` of the campaign, if ``user`` may see the campaign (else "not found");
    a stale one is failed with the reason (in its own short write transaction)."""
    get_for(session, Campaign, campaign_id, user)
    row = session.get(ArtifactBuild, build_id)
    if row is None or row.campaign_id != campaign_id:
        raise NotFound("artifact build", build_id)
    reason = stale_reason(session, row) if row.status in ACTIVE else None
    if reason is not None:
        _fail(session, row, reason)
    return row


def _aware(moment: Any) -> Any:
    """SQLite hands back naive datetimes (stored in UTC)."""
    return moment if moment.tzinfo is not None else moment.replace(tzinfo=UTC)


def stale_reason(session: Session, row: ArtifactBuild) -> str | None:
    """Why an unfinished build will not finish, or None while it may."""
    quiet = utcnow() - _aware(row.touched_at)
    if row.status == ArtifactBuildStatus.running.value:
        dead = dead_worker_reason(session, row.worker_name)
        if dead is not None:
            return f"the worker building it ({row.worker_name}) {dead}. Download again to build anew."
        if quiet > timedelta(seconds=BUILD_TIMEOUT_S + 60):
            return f"no zip was stored for more than {BUILD_TIMEOUT_S + 60} s. Download again to build anew."
        return None
    if quiet <= STALE_AFTER or outbox.waiting(session, [subject(row.id)]):
        return None  # its job waits for the broker: it is sent as soon as the broker is back
    minutes = int(STALE_AFTER.total_seconds() // 60)
    return (
        f"no worker took it from the job queue within {minutes} minutes: is a worker listening on queue "
        f"'{QUEUE}'? Download again to ask anew."
    )


def _fail(session: Session, row: ArtifactBuild, reason: str) -> None:
    from alcove.db import run_transaction

    stmt = (
        sa.update(ArtifactBuild)
        .where(ArtifactBuild.id == row.id, ArtifactBuild.status == row.status, ArtifactBuild.attempts == row.attempts)
        .values(status=ArtifactBuildStatus.failed.value, error=reason, slot=None, finished_at=utcnow())
    )
    if session.in_transaction() and not session.new and not session.dirty and not session.deleted:
        session.commit()

    def fail(s: Session) -> int:
        result = s.execute(stmt)
        assert isinstance(result, sa.CursorResult)
        return result.rowcount

    if run_transaction(fail):
        session.refresh(row)


def detail(session: Session, row: ArtifactBuild) -> str:
    """What the build is doing or waiting for, in words."""
    if row.status == ArtifactBuildStatus.ready.value:
        return "ready: download again"
    if row.status == ArtifactBuildStatus.failed.value:
        return "failed"
    if row.status == ArtifactBuildStatus.running.value:
        return f"building model zip {min(row.models_done + 1, row.models_total)} of {row.models_total}"
    if outbox.waiting(session, [subject(row.id)]):
        return f"{outbox.WAITING_FOR_QUEUE}: the broker is not reachable; it is sent as soon as it is back"
    if row.worker_name:  # a worker took its job and found every build slot taken
        limit = get_settings().artifact_builds
        return f"waiting for a free build slot (at most {limit} builds run at once)"
    from alcove.jobs.heartbeat import live_workers

    if not any(QUEUE in (w.queues or []) for w in live_workers(get_settings().worker_stale_seconds, session)):
        return f"waiting for a worker on queue '{QUEUE}': none is running (start one: alcove worker --queues {QUEUE})"
    return f"waiting for a worker on queue '{QUEUE}'"


def read(session: Session, row: ArtifactBuild) -> ArtifactBuildRead:
    return ArtifactBuildRead(
        id=row.id,
        campaign_id=row.campaign_id,
        status=row.status,
        models_total=row.models_total,
        models_done=row.models_done,
        detail=detail(session, row),
        error=row.error,
        download_url=row.download_path,
        created_at=row.created_at,
        started_at=row.started_at,
        finished_at=row.finished_at,
    )
