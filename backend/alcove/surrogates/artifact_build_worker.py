"""Artifact builds, the worker side: claim the build together with a free build slot (a
conditional update; the slot is unique while held, so at most ``ALCOVE_ARTIFACT_BUILDS`` builds
run at once across all workers, and a duplicate delivery does nothing), build the missing zips
in one child process outside any transaction, counting each stored zip, and record the outcome.
With every slot taken the job answers ``busy`` and the worker sends it again a little later."""

from __future__ import annotations

import logging

import sqlalchemy as sa
from sqlalchemy import exc as sa_exc
from sqlalchemy.orm import Session

from alcove.errors import StorageUnavailable
from alcove.models import ArtifactBuild, ArtifactBuildStatus, ModelVersion, utcnow
from alcove.settings import get_settings
from alcove.surrogates.artifact_builds import stale_reason
from alcove.surrogates.artifact_zips import BuildFailed, build_zips, missing_zips

log = logging.getLogger(__name__)

#: Seconds until a job that found every build slot taken runs again.
BUSY_RETRY_S = 2.0
BUSY = "busy"
QUEUED, RUNNING = ArtifactBuildStatus.queued.value, ArtifactBuildStatus.running.value


def _free_stale_slots(s: Session) -> None:
    """Fail the running builds that will not finish (their worker died), freeing their slots."""
    for row in s.scalars(sa.select(ArtifactBuild).where(ArtifactBuild.slot.is_not(None))):
        reason = stale_reason(s, row)
        if reason is not None:
            row.status, row.error, row.slot, row.finished_at = ArtifactBuildStatus.failed.value, reason, None, utcnow()
    s.flush()


def claim(s: Session, build_id: int, worker_name: str) -> int | str | None:
    """Take the queued build with a free slot: its attempt number; :data:`BUSY` when every
    slot is taken (the build stays queued, touched); None when it is not queued (a duplicate)."""
    row = s.get(ArtifactBuild, build_id)
    if row is None or row.status != QUEUED:
        return None
    _free_stale_slots(s)
    taken = set(s.scalars(sa.select(ArtifactBuild.slot).where(ArtifactBuild.slot.is_not(None))))
    now = utcnow()
    for slot in (n for n in range(get_settings().artifact_builds) if n not in taken):
        try:
            with s.begin_nested():
                got = s.execute(
                    sa.update(ArtifactBuild)
                    .where(ArtifactBuild.id == build_id, ArtifactBuild.status == QUEUED)
                    .values(
                        status=RUNNING,
                        slot=slot,
                        attempts=ArtifactBuild.attempts + 1,
                        worker_name=worker_name,
                        started_at=now,
                        touched_at=now,
                    )
                    .returning(ArtifactBuild.attempts)
                ).first()
        except sa_exc.IntegrityError:  # another worker took this slot at the same moment
            continue
        return None if got is None else int(got[0])
    s.execute(
        sa.update(ArtifactBuild).where(ArtifactBuild.id == build_id).values(touched_at=now, worker_name=worker_name)
    )
    return BUSY


def run_build(build_id: int, worker_name: str) -> str:
    """The worker's job: claim, build, record. Returns the final status, ``skipped`` (not
    queued: a duplicate delivery) or :data:`BUSY` (every build slot taken: send it again)."""
    from alcove.db import open_transaction, run_transaction

    claimed = run_transaction(lambda s: claim(s, build_id, worker_name))
    if claimed is None:
        return "skipped"
    if claimed == BUSY:
        return BUSY
    attempt = int(claimed)
    mine = (ArtifactBuild.id == build_id, ArtifactBuild.status == RUNNING, ArtifactBuild.attempts == attempt)

    def progress(_: int) -> None:
        run_transaction(
            lambda s: s.execute(
                sa.update(ArtifactBuild)
                .where(*mine)
                .values(models_done=ArtifactBuild.models_done + 1, touched_at=utcnow())
            )
        )

    error = None
    try:
        with open_transaction() as s:
            ids = list(s.get_one(ArtifactBuild, build_id).model_version_ids)
            versions = list(s.scalars(sa.select(ModelVersion).where(ModelVersion.id.in_(ids))))
            todo = [mv.id for mv in missing_zips(versions)]  # another build may have stored some meanwhile
            s.execute(sa.update(ArtifactBuild).where(*mine).values(models_done=len(ids) - len(todo)))
        build_zips(todo, progress)
    except StorageUnavailable as err:
        error = err.message
    except BuildFailed as err:
        error = str(err)
    except Exception as err:
        log.exception("artifact build %d failed", build_id)
        error = f"{type(err).__name__}: {err}"[:2000]
    status = ArtifactBuildStatus.failed.value if error else ArtifactBuildStatus.ready.value
    run_transaction(
        lambda s: s.execute(
            sa.update(ArtifactBuild)
            .where(*mine)
            .values(status=status, error=error, slot=None, finished_at=utcnow(), touched_at=utcnow())
        )
    )
    return status


def release_lost_build(build_id: int, worker_name: str) -> bool:
    """In the worker's main process: the pool process running build ``build_id`` died (SIGKILL,
    out of memory). The main process still beats, so the build is failed here with the reason,
    freeing its slot at once; True if it was still running there."""
    from alcove.db import run_transaction

    reason = f"the worker process building it ({worker_name}) died. Download again to build anew."

    def release(s: Session) -> int:
        result = s.execute(
            sa.update(ArtifactBuild)
            .where(
                ArtifactBuild.id == build_id, ArtifactBuild.status == RUNNING, ArtifactBuild.worker_name == worker_name
            )
            .values(status=ArtifactBuildStatus.failed.value, error=reason, slot=None, finished_at=utcnow())
        )
        assert isinstance(result, sa.CursorResult)
        return result.rowcount

    return bool(run_transaction(release))
