"""Downloads that need model artifact zips (``.../artifact.zip``, a campaign's export with
models) and the artifacts folder they are stored in.

A full or read-only artifacts folder is answered at once (503 or 507 naming the folder and the
cause), while the zips already stored are still served unchanged; readiness reports the folder
(to an admin only). A zip not stored yet is built by a worker: the download answers 202 with a
build to poll (the same build for the same download), the build holds one of
``ALCOVE_ARTIFACT_BUILDS`` slots (a slot of a dead worker's build is taken back), and the
download answers 200 once it is ready. The job runs in this process here; through a real worker
process (two builds at once with one slot) it runs in tests/campaigns/test_lifecycle.py."""

from __future__ import annotations

import contextlib
import io
import os
import subprocess
import time
import zipfile
from collections.abc import Iterator
from datetime import timedelta
from pathlib import Path
from typing import Any

import pytest

from tests.helpers import make_account

API = "/api/v1"
#: A fake stored zip: what the folder held before it turned read-only, served byte for byte.
STORED = b"PK a zip stored before the folder turned read-only"


@contextlib.contextmanager
def read_only(folder: Path) -> Iterator[None]:
    """``folder`` read-only for this process: a read-only bind mount (as root, whom file modes
    do not stop), else its mode."""
    if os.geteuid() != 0:
        folder.chmod(0o555)
        try:
            yield
        finally:
            folder.chmod(0o755)
        return
    if subprocess.run(["mount", "--bind", str(folder), str(folder)], capture_output=True).returncode != 0:
        pytest.skip("cannot bind-mount a folder read-only here")
    try:
        subprocess.run(["mount", "-o", "remount,bind,ro", str(folder)], check=True, capture_output=True)
        yield
    finally:
        subprocess.run(["umount", str(folder)], check=True)


@pytest.fixture(scope="module")
def campaign(api_settings: None) -> dict[str, Any]:
    """A finished campaign of a member's: model version 1 a real model (its zip not built),
    version 2 a copy under another artifact hash whose zip is stored (:data:`STORED`)."""
    from alcove.db import open_transaction
    from alcove.db.arrays import put_bytes
    from alcove.models import Iteration, ModelVersion
    from alcove.surrogates.artifact_zips import ZIP_LAYOUT, cache_dir
    from tests.synthetic import synthesize_campaign

    me = make_account("member", "builds")
    with open_transaction() as s:
        c = synthesize_campaign(s, me.id, iterations=2, model=True, name="builds")
        first = s.query(ModelVersion).filter_by(campaign_id=c.id).one()
        second = s.query(Iteration).filter_by(campaign_id=c.id, index=2).one()
        columns = {col.key: getattr(first, col.key) for col in ModelVersion.__table__.columns if col.key != "id"}
        other_artifact = put_bytes(s, b'{"another": "artifact"}', "application/json")
        copy = ModelVersion(**{**columns, "version": 2, "iteration_id": second.id, "artifact_sha256": other_artifact})
        s.add(copy)
        s.flush()
        cid, first_id = c.id, first.id
    (cache_dir() / f"{other_artifact}.v{ZIP_LAYOUT}.zip").write_bytes(STORED)
    return {"campaign_id": cid, "model_version_id": first_id, "account": me}


def _builds(campaign_id: int) -> list:
    from alcove.db import open_transaction
    from alcove.models import ArtifactBuild

    with open_transaction() as s:
        return [(b.id, b.status) for b in s.query(ArtifactBuild).filter_by(campaign_id=campaign_id)]


def test_a_read_only_artifacts_folder_answers_at_once_naming_it_and_keeps_what_is_stored(
    client, admin, campaign, capsys
) -> None:
    from alcove.db import open_transaction
    from alcove.settings import get_settings

    cid, me = campaign["campaign_id"], campaign["account"]
    folder = get_settings().artifacts_dir
    zips = folder / "model-zips"
    before = {p.name: p.read_bytes() for p in zips.iterdir()}
    with read_only(folder):
        stored = client.get(f"{API}/campaigns/{cid}/model-versions/2/artifact.zip", headers=me.headers)
        assert stored.status_code == 200 and stored.content == STORED

        for url in (f"{API}/campaigns/{cid}/model-versions/1/artifact.zip", f"{API}/campaigns/{cid}/export"):
            t0 = time.perf_counter()
            r = client.get(url, headers=me.headers)
            elapsed = time.perf_counter() - t0
            assert r.status_code in (503, 507), r.text
            detail = r.json()["detail"]
            assert str(zips) in detail and ("read-only" in detail or "not writable" in detail), detail
            assert elapsed < 2.0, f"{url} took {elapsed:.1f} s"
        plain = client.get(f"{API}/campaigns/{cid}/export", params={"models": "false"}, headers=me.headers)
        assert (
            plain.status_code == 200
            and f"campaign-{cid}/metrics.csv" in zipfile.ZipFile(io.BytesIO(plain.content)).namelist()
        )

        # a build recorded before the folder turned read-only: the worker fails it at once, naming
        # the cause, and frees its slot
        from alcove.models import ArtifactBuild
        from alcove.surrogates.artifact_build_worker import run_build

        with open_transaction() as s:
            queued = ArtifactBuild(
                campaign_id=cid, model_version_ids=[campaign["model_version_id"]], download_path="/x", models_total=1
            )
            s.add(queued)
            s.flush()
            queued_id = queued.id
        t0 = time.perf_counter()
        assert run_build(queued_id, "test@host") == "failed"
        assert time.perf_counter() - t0 < 2.0
        with open_transaction() as s:
            row = s.get(ArtifactBuild, queued_id)
            assert row.slot is None and str(zips) in row.error and "model artifact zips" in row.error, row.error

        # the build's child process, had the folder turned read-only while it built: exit status 3 and
        # the cause named, no temporary file left
        from alcove.surrogates.artifact_zips import EXIT_STORAGE, main

        assert main([str(zips), str(campaign["model_version_id"])]) == EXIT_STORAGE
        said = capsys.readouterr().err
        assert "cannot store model version" in said and "read-only" in said and str(zips) in said, said

        ready = client.get(f"{API}/health/ready", headers=admin.headers).json()
        assert not ready["artifacts"]["ok"] and str(folder) in ready["artifacts"]["detail"], ready
        assert set(client.get(f"{API}/health/ready").json()) == {"ready"}
    assert [b for b in _builds(cid) if b[0] != queued_id] == []  # nothing queued that could not be stored
    assert {p.name: p.read_bytes() for p in zips.iterdir()} == before  # nothing lost, nothing half-written
    assert client.get(f"{API}/health/ready", headers=admin.headers).json()["artifacts"]["ok"]


def test_a_download_waits_for_its_build_within_the_slot_limit_then_answers_the_zip(client, other, campaign) -> None:
    from alcove.db import open_transaction
    from alcove.models import ArtifactBuild, WorkerHeartbeat, utcnow
    from alcove.settings import get_settings
    from alcove.surrogates.artifact_build_worker import run_build

    cid, me = campaign["campaign_id"], campaign["account"]
    url = f"{API}/campaigns/{cid}/model-versions/1/artifact.zip"
    first = client.get(url, headers=me.headers)
    assert first.status_code == 202, first.text
    build = first.json()
    assert build["status"] == "queued" and build["models_total"] == 1 and build["models_done"] == 0
    assert build["download_url"] == url
    none = "waiting for a worker on queue 'artifacts': none is running (start one: alcove worker --queues artifacts)"
    assert build["detail"] == none, build
    location = first.headers["Location"]
    assert location == f"{API}/campaigns/{cid}/artifact-builds/{build['id']}"
    assert client.get(url, headers=me.headers).json()["id"] == build["id"]  # the same download: the same build
    with open_transaction() as s:  # a build under way that also makes zips stored since still covers the download
        s.get(ArtifactBuild, build["id"]).model_version_ids = [campaign["model_version_id"], 10**6]
    assert client.get(url, headers=me.headers).json()["id"] == build["id"]
    with open_transaction() as s:
        s.get(ArtifactBuild, build["id"]).model_version_ids = [campaign["model_version_id"]]
    assert client.get(location, headers=other.headers).status_code == 404

    # every slot held by a running build of a live worker: the job leaves it queued ("busy")
    limit = get_settings().artifact_builds
    names = [f"busy-{i}@host" for i in range(limit)]
    with open_transaction() as s:
        for i, name in enumerate(names):
            s.add(WorkerHeartbeat(name=name, queues=["artifacts"]))
            s.add(
                ArtifactBuild(
                    campaign_id=cid,
                    model_version_ids=[0],
                    download_path="/elsewhere",
                    status="running",
                    slot=i,
                    worker_name=name,
                    attempts=1,
                )
            )
    alive = client.get(location, headers=me.headers).json()["detail"]
    assert alive == "waiting for a worker on queue 'artifacts'", alive  # the busy workers serve the queue
    assert run_build(build["id"], "test@host") == "busy"
    waiting = client.get(location, headers=me.headers).json()
    assert waiting["status"] == "queued" and waiting["detail"].startswith("waiting for a free build slot"), waiting

    # one holder's worker died: its slot is taken back, the build runs and the download answers the zip
    with open_transaction() as s:
        hb = s.query(WorkerHeartbeat).filter_by(name=names[0]).one()
        hb.last_seen_at = utcnow() - timedelta(seconds=get_settings().worker_dead_seconds + 5)
    assert run_build(build["id"], "test@host") == "ready"
    assert run_build(build["id"], "test@host") == "skipped"  # a redelivered message does nothing
    done = client.get(location, headers=me.headers).json()
    assert done["status"] == "ready" and done["models_done"] == 1 and done["error"] is None, done
    with open_transaction() as s:
        dead = s.query(ArtifactBuild).filter_by(worker_name=names[0]).one()
        assert dead.status == "failed" and dead.slot is None and names[0] in dead.error
    # the other holder's pool process died (its worker's main process still beats): released at once
    from alcove.surrogates.artifact_build_worker import release_lost_build

    with open_transaction() as s:
        lost = s.query(ArtifactBuild).filter_by(worker_name=names[1]).one().id
    assert release_lost_build(lost, names[1]) and not release_lost_build(lost, names[1])
    with open_transaction() as s:
        row = s.get(ArtifactBuild, lost)
        assert row.status == "failed" and row.slot is None and f"({names[1]}) died" in row.error
        s.query(ArtifactBuild).filter(ArtifactBuild.worker_name.in_(names)).delete()  # free any other slots

    zipped = client.get(url, headers=me.headers)
    assert zipped.status_code == 200, zipped.text
    assert {"surrogate.json", "force.pt", "moment.pt"} <= set(zipfile.ZipFile(io.BytesIO(zipped.content)).namelist())
    export = client.get(f"{API}/campaigns/{cid}/export", params={"pool_format": "csv"}, headers=me.headers)
    assert export.status_code == 200, export.text
    inside = zipfile.ZipFile(io.BytesIO(export.content))
    assert inside.read(f"campaign-{cid}/models/model-0001.zip") == zipped.content
    assert inside.read(f"campaign-{cid}/models/model-0002.zip") == STORED


def test_a_full_artifacts_folder_answers_507_naming_it(client, campaign) -> None:
    from alcove.settings import get_settings

    if os.geteuid() != 0:
        pytest.skip("mounting a small file system needs root")
    zips = get_settings().artifacts_dir / "model-zips"
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(zips)], capture_output=True).returncode:
        pytest.skip("cannot mount a small file system here")
    try:
        r = client.get(
            f"{API}/campaigns/{campaign['campaign_id']}/model-versions/1/artifact.zip",
            headers=campaign["account"].headers,
        )
    finally:
        subprocess.run(["umount", str(zips)], check=True)
    assert r.status_code == 507 and str(zips) in r.json()["detail"] and "is full" in r.json()["detail"], r.text
